"""Several days in one call: a folder per day, one metrics.json, resume after a kill."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app

runner = CliRunner()
# One study square: a folder per day right below --out (a city's, per hub below).
SQUARE = ["--area", "square"]


def _replay(example_csv: Path, out: Path, *extra: str) -> None:
    res = runner.invoke(
        app,
        [
            "replay-day",
            *SQUARE,
            str(example_csv),
            "--dates",
            "0811..0812",
            "--method",
            "greedy",
            "--out",
            str(out),
            *extra,
        ],
    )
    assert res.exit_code == 0, res.output


def test_dates_layout_and_resume(example_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "week"
    _replay(example_csv, out)
    for day in ("2022-08-11", "2022-08-12"):
        folder = out / day
        assert {p.name for p in folder.iterdir()} == {
            "stops.parquet",
            "routes.parquet",
            "metrics.json",
        }
    top = json.loads((out / "metrics.json").read_text())
    assert [d["day"] for d in top["days"]] == ["2022-08-11", "2022-08-12"]
    # the aggregate over the days: counts add up, delay is per request
    total, days = top["total"], top["days"]
    assert total["days"] == 2
    assert total["delivered"] == sum(d["delivered"] for d in days)
    assert total["requests"] == total["delivered"] + total["undelivered"]
    expect = sum(d["avg_delay_h"] * d["requests"] for d in days) / total["requests"]
    assert abs(total["avg_delay_h"] - expect) < 1e-12
    # A killed run left day 2 unfinished: only day 2 is replayed, day 1 is kept as it was.
    day1 = out / "2022-08-11" / "stops.parquet"
    mtime = day1.stat().st_mtime_ns
    (out / "2022-08-12" / "metrics.json").unlink()
    _replay(example_csv, out)
    assert day1.stat().st_mtime_ns == mtime
    assert (out / "2022-08-12" / "metrics.json").is_file()
    again = json.loads((out / "metrics.json").read_text())
    assert again["days"] == top["days"][:1] + again["days"][1:]
    assert again["days"][1]["delivered"] == top["days"][1]["delivered"]
    # A day whose stops were lost since is replayed too, not taken for done.
    (out / "2022-08-12" / "stops.parquet").unlink()
    _replay(example_csv, out)
    assert day1.stat().st_mtime_ns == mtime
    assert (out / "2022-08-12" / "stops.parquet").is_file()
    # --force replays everything.
    _replay(example_csv, out, "--force")
    assert day1.stat().st_mtime_ns != mtime


def test_rerun_with_other_settings_is_refused_and_changes_nothing(
    example_csv: Path, tmp_path: Path
) -> None:
    """A folder replayed with one setting is not silently reused for another: exit 2,
    a line naming the day's file and what differs, every file left as it was."""
    out = tmp_path / "week"
    _replay(example_csv, out)
    before = {p: p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}
    args = ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812", "--out", str(out)]
    res = runner.invoke(app, [*args, "--method", "greedy", "--alpha", "0.9"])
    assert res.exit_code == 2
    assert "2022-08-11/metrics.json" in res.output
    assert "config.plan.alpha: 0.5 here, 0.9 now" in res.output
    assert "--force" in res.output
    assert {p: p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()} == before
    # Another method with the same settings otherwise: refused as well.
    res = runner.invoke(app, [*args, "--method", "stay"])
    assert res.exit_code == 2 and "method: 'greedy' here, 'stay' now" in res.output
    # The same settings again: kept and skipped, the days' numbers unchanged.
    res = runner.invoke(app, [*args, "--method", "greedy"])
    assert res.exit_code == 0 and res.output.count("skipped") == 2
    days = json.loads((out / "2022-08-11" / "metrics.json").read_text())
    assert days["meta"]["settings"]["method"] == "greedy"
    assert days["meta"]["settings"]["frame"]["size_km"] == 10.0


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        (lambda d: d["days"][0].__setitem__("delivered", "lots"), "days[0].delivered"),
        (lambda d: d["days"][0].pop("requests"), "days[0].requests"),
        (lambda d: d["days"][0].__setitem__("energy_kj", None), "days[0].energy_kj"),
        (lambda d: d["days"][0].__setitem__("co2_g", 10**400), "days[0].co2_g"),
        (lambda d: d["days"][0].__setitem__("day", "2022-08-12"), "days[0].day"),
        (lambda d: d.__setitem__("days", []), "days"),
        (lambda d: d.__setitem__("days", ["x"]), "days"),
        (lambda d: d.__setitem__("days", d["days"] * 2), "days"),
    ],
    ids=["text-count", "no-requests", "null-energy", "huge", "other-day", "none", "text", "twice"],
)
def test_an_edited_earlier_day_is_refused_naming_its_key(
    example_csv: Path, tmp_path: Path, fails_cleanly, edit, key
) -> None:
    """A day folder kept on a rerun must hold the day's record as marops wrote it: one
    whose counts were edited to text or removed was a traceback while summing the days
    (TypeError, KeyError), one of another day or none at all went into the totals."""
    out = tmp_path / "week"
    _replay(example_csv, out)
    path = out / "2022-08-11" / "metrics.json"
    doc = json.loads(path.read_text())
    edit(doc)
    path.write_text(json.dumps(doc))
    args = ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812"]
    args += ["--method", "greedy"]
    line = fails_cleanly([*args, "--out", str(out)], tmp_path, str(path), "--force")
    assert f"key '{key}'" in line, line


def test_json_format_matches_parquet(example_csv: Path, tmp_path: Path) -> None:
    for fmt in ("parquet", "json"):
        res = runner.invoke(
            app,
            [
                "replay-day",
                *SQUARE,
                str(example_csv),
                "--date",
                "0812",
                "--method",
                "ops-random",
                "--format",
                fmt,
                "--out",
                str(tmp_path / fmt),
            ],
        )
        assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "json" / "stops.json").read_text())
    assert doc["meta"]["method"] == "ops-random"
    table = pq.read_table(tmp_path / "parquet" / "stops.parquet").to_pylist()
    assert len(doc["stops"]) == len(table)
    assert [r["order_id"] for r in doc["stops"]] == [r["order_id"] for r in table]
    assert [r["leg_j"] for r in doc["stops"]] == [r["leg_j"] for r in table]
    routes = json.loads((tmp_path / "json" / "routes.json").read_text())["routes"]
    assert len(routes) == 8 * 16


def test_says_what_was_left_out_and_warns_when_much_stays_undelivered(
    example_csv: Path, tmp_path: Path
) -> None:
    args = ["replay-day", *SQUARE, str(example_csv), "--date", "0811", "--method", "stay"]
    res = runner.invoke(app, [*args, "--drones", "1", "--out", str(tmp_path / "one")])
    assert res.exit_code == 0, res.output
    day = json.loads((tmp_path / "one" / "metrics.json").read_text())["days"][0]
    assert day["orders_due"] == day["requests"] + day["outside_area"] + day["outside_hours"]
    assert f"{day['orders_due']:,} orders due, {day['requests']:,} planned" in res.output
    assert f"{day['outside_area']:,} outside the 10 km study area" in res.output
    assert day["undelivered"] > 0.1 * day["requests"]
    assert "warning: 2022-08-11:" in res.output
    assert "stayed undelivered with 1 drone\n" in res.output
    res = runner.invoke(app, [*args, "--drones", "16", "--out", str(tmp_path / "many")])
    day = json.loads((tmp_path / "many" / "metrics.json").read_text())["days"][0]
    assert (day["undelivered"] > 0.1 * day["requests"]) == ("warning:" in res.output)


def test_days_on_workers_are_the_days_planned_here(example_csv: Path, tmp_path: Path) -> None:
    """Several days go to worker processes (docs/decisions.md, "Workers"): every route
    file is the same bytes as when this process plans them one after another, the day
    metrics agree, and a worker's plot reaches its day folder."""
    outs = {}
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}"
        args = ["replay-day", *SQUARE, str(example_csv), "--dates", "0810..0812"]
        args += ["--method", "myopic"]
        res = runner.invoke(app, [*args, "--workers", workers, "--plot", "--out", str(out)])
        assert res.exit_code == 0, res.output
        outs[workers] = out
    assert "3 days to replay on 2 workers" in res.output
    for day in ("2022-08-10", "2022-08-11", "2022-08-12"):
        for name in ("stops.parquet", "routes.parquet"):
            assert (outs["1"] / day / name).read_bytes() == (outs["2"] / day / name).read_bytes()
        for png in ("routes.png", "operations.png"):
            assert (outs["2"] / day / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    a, b = (json.loads((o / "metrics.json").read_text()) for o in outs.values())
    drop = {"runtime_s", "solver"}  # wall times (the solver's among its counts)
    assert [{k: v for k, v in d.items() if k not in drop} for d in a["days"]] == [
        {k: v for k, v in d.items() if k not in drop} for d in b["days"]
    ]


def test_ctrl_c_keeps_the_finished_days_and_a_rerun_replays_the_rest(
    example_csv: Path, tmp_path: Path, stop_marops
) -> None:
    """Days on workers: Ctrl-C stops the run with one line (exit 130), every day
    written so far stays whole, and the same command replays only the others."""
    import signal

    out = tmp_path / "days"
    args = ["replay-day", *SQUARE, str(example_csv), "--dates", "0801..0812"]
    args += ["--method", "greedy", "--workers", "2", "--out", str(out)]
    code, err = stop_marops(args, lambda: any(out.glob("*/metrics.json")), signal.SIGINT)
    assert code == 130, err
    assert "Traceback" not in err and "of 12 days are written" in err
    kept = sorted(p.parent.name for p in out.glob("*/metrics.json"))
    assert 1 <= len(kept) < 12 and not (out / "metrics.json").exists()
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert res.output.count("skipped") == len(kept)
    assert len(json.loads((out / "metrics.json").read_text())["days"]) == 12


def test_a_rerun_names_a_few_kept_days_each_and_many_in_one_line() -> None:
    """Re-running a month to add a day says once that the others are kept, not 30 times."""
    import datetime as dt

    from marops_cli.app.replay_areas import _say_kept

    class Said:
        def __init__(self) -> None:
            self.lines: list[str] = []

        def message(self, text: str) -> None:
            self.lines.append(text)

    days = [dt.date(2022, 8, d) for d in range(1, 31)]
    kept = [(d.isoformat(), Path("out") / d.isoformat()) for d in days]
    said = Said()
    _say_kept(kept[:3], [], said)  # type: ignore[arg-type]
    assert len(said.lines) == 3
    assert said.lines[0] == (
        "2022-08-01: output with the same settings exists in out/2022-08-01, "
        "skipped (--force replays)"
    )
    said = Said()
    _say_kept(kept, [], said)  # type: ignore[arg-type]
    assert said.lines == [
        "30 days have output with the same settings (2022-08-01 … 2022-08-30), "
        "skipped (--force replays)"
    ]


def test_a_rerun_over_another_range_is_not_taken_for_the_same_settings(
    example_csv: Path, tmp_path: Path
) -> None:
    """A day's routes depend on the range replayed: the file's other days give the
    arrival profile (and, without --depots, the depots). A day replayed within
    0810..0811 is not kept by a rerun over 0809..0811 (the depots a file, so they are
    the same): refused naming the history days, --force replays."""
    out = tmp_path / "week"
    depots = tmp_path / "depots.json"
    res = runner.invoke(app, ["segment", str(example_csv), "--out", str(depots), "-q"])
    assert res.exit_code == 0, res.output
    args = ["replay-day", str(example_csv), "--method", "stay", "--depots", str(depots)]
    res = runner.invoke(app, [*args, "--dates", "0810..0811", "--out", str(out), "-q"])
    assert res.exit_code == 0, res.output
    before = {p: p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}
    res = runner.invoke(app, [*args, "--dates", "0809..0811", "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert "2022-08-10/metrics.json" in res.output and "history_days: '" in res.output
    assert "2022-08-01..2022-08-09, 2022-08-12' here" in res.output.replace("\n", "")
    assert {p: p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()} == before
    res = runner.invoke(app, [*args, "--dates", "0809..0811", "--out", str(out), "--force"])
    assert res.exit_code == 0, res.output
    settings = json.loads((out / "2022-08-11" / "metrics.json").read_text())["meta"]["settings"]
    history = settings["history_days"]  # the file's days but those replayed
    assert "2022-08-08" in history and "2022-08-12" in history
    assert not {"2022-08-09", "2022-08-10", "2022-08-11"} & set(history)
    # The same range again: the same settings, kept.
    res = runner.invoke(app, [*args, "--dates", "0809..0811", "--out", str(out)])
    assert res.exit_code == 0 and res.output.count("skipped") == 3, res.output


def test_a_day_another_run_wrote_meanwhile_is_not_claimed_by_the_summary(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A day's folder written by another run while this one ran (its metrics.json
    replaced after this run wrote it) is not reported in this run's metrics.json: one
    line naming the day's folder, exit 2, and no summary."""
    import os

    from marops_cli.app import replay_areas

    finish = replay_areas._finish_day

    def and_another_run_writes(area, day, out, run, progress):  # type: ignore[no-untyped-def]
        got = finish(area, day, out, run, progress)
        folder = area.folder(day)
        if folder is not None and day.isoformat() == "2022-08-11":
            doc = json.loads((folder / "metrics.json").read_text())
            doc["meta"]["settings"]["config"]["plan"]["alpha"] = 0.3  # another run's
            (folder / "other.json").write_text(json.dumps(doc))
            os.replace(folder / "other.json", folder / "metrics.json")
        return got

    monkeypatch.setattr(replay_areas, "_finish_day", and_another_run_writes)
    out = tmp_path / "week"
    res = runner.invoke(
        app,
        ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812", "--method", "stay"]
        + ["--out", str(out)],
    )
    assert res.exit_code == 2, res.output
    line = res.stderr.strip().splitlines()[-1]
    assert line.startswith(f"marops: error: {out / '2022-08-11'}: was written by another run")
    assert "metrics.json is not the file this run wrote" in line
    assert not (out / "metrics.json").exists()


def test_a_day_whose_route_files_are_not_its_own_is_replayed(
    example_csv: Path, tmp_path: Path
) -> None:
    """A day is kept only when its route files are the run's output for that day (their
    marops metadata): another day's copied in, or a window that plan-window wrote into
    the day's folder, is replayed over (the files are marops's), not claimed as the day."""
    out = tmp_path / "week"
    _replay(example_csv, out)
    day = out / "2022-08-12"
    for name in ("stops.parquet", "routes.parquet"):
        (day / name).write_bytes((out / "2022-08-11" / name).read_bytes())
    res = runner.invoke(
        app,
        ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812", "--method", "greedy"]
        + ["--out", str(out)],
    )
    assert res.exit_code == 0, res.output
    assert res.output.count("skipped") == 1 and "2022-08-11: output with" in res.output
    for name in ("stops.parquet", "routes.parquet"):
        meta = json.loads(pq.read_schema(day / name).metadata[b"marops"])
        assert meta["day"] == "2022-08-12"
    assert {r["day"].isoformat() for r in pq.read_table(day / "stops.parquet").to_pylist()} == {
        "2022-08-12"
    }
    # A window planned into the day's folder by plan-window: replayed over as well.
    depots = tmp_path / "depots.json"
    res = runner.invoke(app, ["segment", str(example_csv), "--out", str(depots), "-q"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(
        app,
        ["plan-window", str(example_csv), "--depots", str(depots), "--date", "0812"]
        + ["--window", "3", "--out", str(day), "-q"],
    )
    assert res.exit_code == 0, res.output
    res = runner.invoke(
        app,
        ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812", "--method", "greedy"]
        + ["--out", str(out)],
    )
    assert res.exit_code == 0, res.output
    assert res.output.count("skipped") == 1
    meta = json.loads(pq.read_schema(day / "routes.parquet").metadata[b"marops"])
    assert meta["command"] == "replay-day" and meta["day"] == "2022-08-12"
    # The same command again keeps both days.
    res = runner.invoke(
        app,
        ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812", "--method", "greedy"]
        + ["--out", str(out)],
    )
    assert res.exit_code == 0 and res.output.count("skipped") == 2, res.output


def test_days_of_json_route_files_are_kept_by_their_metadata(
    example_csv: Path, tmp_path: Path
) -> None:
    """``--format json``: a rerun keeps the days whose route files (and routes.geojson)
    are the run's for that day, and replays one whose routes.json is another day's."""
    out = tmp_path / "week"
    _replay(example_csv, out, "--format", "json", "--geojson")
    assert (out / "2022-08-12" / "routes.json").is_file()
    res = runner.invoke(
        app,
        ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812", "--method", "greedy"]
        + ["--format", "json", "--geojson", "--out", str(out)],
    )
    assert res.exit_code == 0 and res.output.count("skipped") == 2, res.output
    day = out / "2022-08-12" / "routes.geojson"
    day.write_bytes((out / "2022-08-11" / "routes.geojson").read_bytes())
    res = runner.invoke(
        app,
        ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812", "--method", "greedy"]
        + ["--format", "json", "--geojson", "--out", str(out)],
    )
    assert res.exit_code == 0 and res.output.count("skipped") == 1, res.output
    assert json.loads(day.read_text())["marops"]["day"] == "2022-08-12"


def test_a_day_replayed_again_loses_the_earlier_runs_extra_files(
    example_csv: Path, tmp_path: Path
) -> None:
    """A day replayed over an earlier run's (--force) removes that run's outputs it does
    not write again (its map, figures, route files of the other format), so a later
    rerun does not keep them as its own; a file marops did not write stays."""
    out = tmp_path / "day"
    args = ["replay-day", *SQUARE, str(example_csv), "--date", "0811", "--method", "greedy"]
    args += ["--out", str(out)]
    res = runner.invoke(app, [*args, "--geojson", "--plot", "--format", "json"])
    assert res.exit_code == 0, res.output
    (out / "report.html").write_text("<p>notes of mine</p>")
    res = runner.invoke(app, [*args, "--alpha", "0.9", "--force"])
    assert res.exit_code == 0, res.output
    assert {p.name for p in out.iterdir() if not p.name.startswith(".")} == {
        "stops.parquet",
        "routes.parquet",
        "metrics.json",
        "report.html",
    }
    assert (out / "report.html").read_text() == "<p>notes of mine</p>"
    # Asked for the map now: the day is replayed to write it, with these settings.
    res = runner.invoke(app, [*args, "--alpha", "0.9", "--geojson"])
    assert res.exit_code == 0 and "skipped" not in res.output, res.output
    geo = json.loads((out / "routes.geojson").read_text())
    assert geo["marops"]["config"]["plan"]["alpha"] == 0.9


@pytest.mark.parametrize(
    ("where", "summaries"),
    [
        (["--dates", "0811..0812", "--report"], ["metrics.json", "report.html"]),
        (["--date", "0811", "--area", "hubs"], ["metrics.json", "left_out.csv"]),
    ],
    ids=["days", "city"],
)
def test_a_rerun_stopped_after_its_first_day_leaves_no_summary_of_the_earlier_run(
    example_csv: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    where: list[str],
    summaries: list[str],
) -> None:
    """--force replays days over an earlier run's: the summary over them (metrics.json of
    several days and its page, a city's metrics.json and left_out.csv) goes before the
    first day is replaced, so a run stopped then leaves none claiming the earlier run's
    numbers for a day that holds this run's files."""
    from marops_cli.app import replay_areas

    out = tmp_path / "out"
    args = ["replay-day", str(example_csv), *where, "--method", "stay", "--out", str(out)]
    if "--area" not in where:
        args += SQUARE
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert all((out / name).is_file() for name in summaries)
    finish = replay_areas._finish_day

    def and_stopped(area, day, out, run, progress):  # type: ignore[no-untyped-def]
        finish(area, day, out, run, progress)
        raise KeyboardInterrupt  # the run stops right after its first day's files

    monkeypatch.setattr(replay_areas, "_finish_day", and_stopped)
    res = runner.invoke(app, [*args, "--alpha", "0.9", "--force"])
    assert res.exit_code == 130, res.output

    def alpha(path: Path) -> float:
        return json.loads(path.read_text())["meta"]["settings"]["config"]["plan"]["alpha"]

    days = sorted(p for p in out.rglob("metrics.json") if p.parent != out)
    replaced = [p for p in days if alpha(p) == 0.9]
    assert len(days) > 1 and len(replaced) == 1, replaced
    assert not any((out / name).exists() for name in summaries)


def test_more_workers_than_the_cpus_run_are_one_warning(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--workers past 4 per CPU is no error: the run starts 4 per CPU, says so in one
    line, and writes its days as any number of workers does."""
    from marops_cli.workers import pool

    monkeypatch.setattr(pool, "usable_cpus", lambda: 1)
    monkeypatch.setattr(pool, "PER_CPU", 1)  # one process: the days run here
    out = tmp_path / "days"
    res = runner.invoke(
        app,
        ["replay-day", *SQUARE, str(example_csv), "--dates", "0811..0812", "--method", "stay"]
        + ["--workers", "2", "--out", str(out)],
    )
    assert res.exit_code == 0, res.output
    line = (
        "warning: --workers 2 is more than 1 per CPU this process may use (1): 1 worker "
        "process run (the results are the same)"
    )
    assert " ".join(res.output.split()).count(line) == 1, res.output
    assert "on 1 workers" in res.output
    assert len(json.loads((out / "metrics.json").read_text())["days"]) == 2


def test_many_short_days_are_one_warning_naming_the_worst() -> None:
    """A few days left short of drones are a line each; many (a city's hub-days) one
    line, with the count and the three worst; the same for requests no drone serves."""
    from marops_cli.app.messages import undelivered

    class Said:
        def __init__(self) -> None:
            self.lines: list[str] = []

        def warning(self, text: str) -> None:
            self.lines.append(text)

    def day(hub: int, short: int, far: int = 0) -> tuple[dict[str, int | str], int, str]:
        m = {"day": "2022-08-11", "requests": 100, "undelivered": short, "unservable_far": far}
        return m, 2, f"hub {hub}: "

    said = Said()
    undelivered(said, [day(0, 50), day(1, 5), day(2, 30, far=1)])  # type: ignore[arg-type]
    assert said.lines == [
        "hub 2: 2022-08-11: 0 parcels heavier than the payload limit and 1 requests beyond "
        "any drone's reach from the nearest depot cannot be served",
        "hub 0: 2022-08-11: 50 of 100 requests (50%) stayed undelivered with 2 drones",
        "hub 2: 2022-08-11: 30 of 100 requests (30%) stayed undelivered with 2 drones",
    ]
    said = Said()
    days = [day(h, short, far=1) for h, short in enumerate([20, 5, 60, 40, 30, 11])]
    undelivered(said, days)  # type: ignore[arg-type]
    assert said.lines == [
        "6 of 6 hub-days: 0 parcels heavier than the payload limit and 6 requests beyond "
        "any drone's reach from the nearest depot cannot be served, in all; each day's "
        "metrics (metrics.json) count them (unservable_heavy, unservable_far)",
        "5 of 6 hub-days: more than 10% of their requests stayed undelivered, the most "
        "hub 2: 2022-08-11 (60% of 100, with 2 drones), hub 3: 2022-08-11 (40% of 100, "
        "with 2 drones), hub 4: 2022-08-11 (30% of 100, with 2 drones); each day's "
        "metrics (metrics.json) count them (undelivered, requests)",
    ]

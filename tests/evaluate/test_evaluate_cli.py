"""``marops evaluate`` usage: help, and one-line errors (exit 2) that write nothing."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app

runner = CliRunner()


def test_help() -> None:
    res = runner.invoke(app, ["evaluate", "--help"])
    assert res.exit_code == 0
    for flag in ("--methods", "--split", "--repeats", "--drones", "--alpha", "--workers"):
        assert flag in res.output


def test_bad_method_name(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "greedy,mapo", "--out", str(out)]
    fails_cleanly(args, tmp_path, "unknown method 'mapo'", "ops-global")


def test_learned_method_without_actor_names_what_is_missing(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fails_cleanly
) -> None:
    monkeypatch.setenv("MAROPS_POLICY", str(tmp_path / "missing.pt"))
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "marops,greedy", "--out", str(out)]
    fails_cleanly(args, tmp_path, "missing", "--policy")


def test_mappo_without_actor_names_its_flag(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "mappo", "--out", str(out)]
    args += ["--mappo-policy", str(tmp_path / "none.pt")]
    fails_cleanly(args, tmp_path, "none.pt", "--mappo-policy")


def test_dates_and_split_exclusive(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--dates", "0811", "--split", "test", "--out", str(out)]
    fails_cleanly(args, tmp_path, "--dates", "--split")


@pytest.mark.parametrize(
    ("flags", "needles"),
    [
        (["--dates", ""], ["--dates", "got ''"]),  # a script's empty list of days
        (["--dates", " "], ["--dates"]),
        (["--split", ""], ["--split", "got ''"]),
        (["--dates", "", "--split", "train"], ["--dates"]),
    ],
)
def test_empty_dates_or_split_is_refused_not_read_as_the_test_split(
    example_csv: Path, tmp_path: Path, fails_cleanly, flags: list[str], needles: list[str]
) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "stay", *flags, "--out", str(out)]
    fails_cleanly(args, tmp_path, *needles)


@pytest.mark.parametrize("methods", ["stay,,greedy", "stay,", ",stay"])
def test_an_empty_method_in_the_list_is_refused(
    example_csv: Path, tmp_path: Path, fails_cleanly, methods: str
) -> None:
    """As an empty sweep value is: before, the empty item was dropped without a word."""
    args = ["evaluate", str(example_csv), "--dates", "0811", "--methods", methods]
    fails_cleanly([*args, "--out", str(tmp_path / "out")], tmp_path, "--methods", repr(methods))


@pytest.mark.parametrize(
    ("flags", "named"),
    [
        (["--alpha", "0"], "--alpha"),
        (["--drones", "0"], "--drones"),
        (["--coverage", "5"], "--coverage"),
        (["--n-depots", "1,0"], "--n-depots"),
    ],
)
def test_a_bad_sweep_value_names_its_option(
    example_csv: Path, tmp_path: Path, fails_cleanly, flags: list[str], named: str
) -> None:
    """Named by the option that swept it, as replay-day names it (was plan.alpha,
    sim.drones, plan.coverage, segment.n_depots); the API names the keyword."""
    args = ["evaluate", str(example_csv), "--dates", "0811", "--methods", "stay", *flags]
    fails_cleanly([*args, "--out", str(tmp_path / "out")], tmp_path, f"invalid option {named}:")


def test_api_a_bad_sweep_value_names_its_keyword(example_csv: Path) -> None:
    from marops_cli import api
    from marops_cli.errors import InputError

    with pytest.raises(InputError, match="invalid option alpha: ") as err:
        api.evaluate(example_csv, dates="0811", methods="stay", alpha=[1e-20], workers=1)
    assert "plan.alpha" not in str(err.value)


def test_api_empty_dates_is_refused(example_csv: Path, tmp_path: Path) -> None:
    from marops_cli import api
    from marops_cli.errors import InputError

    with pytest.raises(InputError, match="^invalid option dates: "):
        api.evaluate(example_csv, methods="stay", dates="", workers=1)
    with pytest.raises(InputError, match="dates expects .* a non-empty list, got list"):
        api.evaluate(example_csv, methods="stay", dates=[], workers=1)
    assert not any(tmp_path.iterdir())


def test_bad_sweep_value(example_csv: Path, tmp_path: Path, fails_cleanly) -> None:
    out = tmp_path / "out"
    args = ["evaluate", str(example_csv), "--methods", "greedy", "--alpha", "0.5,2"]
    fails_cleanly([*args, "--out", str(out)], tmp_path, "alpha")


@pytest.mark.parametrize("value", ["0", "-3", "1001", "1000000000000"])
def test_repeats_out_of_range_is_refused_up_front(
    example_csv: Path, tmp_path: Path, fails_cleanly, value: str
) -> None:
    """A huge --repeats once built a job list that filled memory: now the bound of
    docs/config.md, one line naming the option, before any replay."""
    from marops_cli.evaluate.settings import MAX_REPEATS

    args = ["evaluate", str(example_csv), "--methods", "greedy", "--repeats", value]
    needles = ("invalid option --repeats: ", f"1 ≤ repeats ≤ {MAX_REPEATS}", "docs/config.md")
    fails_cleanly([*args, "--out", str(tmp_path / "out")], tmp_path, *needles)
    help_text = runner.invoke(app, ["evaluate", "--help"]).output
    # the help's words wrap inside its box at the default 80 columns: read past the rules
    assert f"at most {MAX_REPEATS}" in " ".join(help_text.replace("│", " ").split())


def test_a_sweep_of_too_many_replays_is_refused_up_front(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """Thousands of --alpha values × a thousand --drones grew to gigabytes before failing:
    more replays than docs/config.md allows is one line naming the flags and the counts,
    before anything is read or written."""
    from marops_cli.evaluate.settings import MAX_REPLAYS

    alpha = ",".join(str(i / 1000) for i in range(1, 3001))
    drones = ",".join(str(i) for i in range(1, 1001))
    args = ["evaluate", str(example_csv), "--methods", "stay", "--alpha", alpha]
    needles = ("3,000,000 replays (3,000 --alpha values × 1,000 --drones values)",)
    needles += (f"{MAX_REPLAYS:,}", "docs/config.md")
    fails_cleanly([*args, "--drones", drones, "--out", str(tmp_path / "out")], tmp_path, *needles)
    args = [*args[:-1], alpha[:1000], "--repeats", "1000", "--out", str(tmp_path / "out")]
    fails_cleanly(args, tmp_path, "× 1 method × 1,000 repeats)")


def _readme_evaluate_line() -> list[str]:
    """The README's `marops evaluate …` line of the commands table, its optional parts
    ([--workers N] …) left out."""
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text(encoding="utf-8")
    (cell,) = re.findall(r"^\| `(marops evaluate DATA [^`]*)` \|", readme, flags=re.M)
    return re.sub(r"\[[^\]]*\]", "", cell.replace("\\|", "|")).split()


def _one_district(example_csv: Path, out: Path) -> Path:
    """The example's rows within about 4 km of its median point, as they are: an export
    whose whole city is one hub (the example's is twelve)."""
    lines = example_csv.read_text(encoding="utf-8").splitlines()
    located = [
        (line, float(f[4]), float(f[5]))
        for line in lines[1:]
        if re.fullmatch(r"[\d.]+", (f := line.split(","))[4]) and re.fullmatch(r"[\d.]+", f[5])
    ]
    lng = sorted(x for _, x, _ in located)[len(located) // 2]
    lat = sorted(y for _, _, y in located)[len(located) // 2]
    near = [line for line, x, y in located if abs(x - lng) < 0.04 and abs(y - lat) < 0.035]
    out.write_text("\n".join([lines[0], *near]) + "\n", encoding="utf-8")
    return out


def test_the_readme_evaluate_line_runs(example_csv: Path, tmp_path: Path) -> None:
    """As written (the default methods, --against myopic, every hub of the export), on
    one held-out day of a district's export: one hub's 30 replays, not the example
    city's 360."""
    words = _readme_evaluate_line()
    assert words[:3] == ["marops", "evaluate", "DATA"] and "--against" in words
    at = words.index("--split")
    words[at : at + 2] = ["--dates", "0811"]  # one day instead of the file's last 20 %
    data = _one_district(example_csv, tmp_path / "district.csv")
    args = [{"DATA": str(data), "DIR": str(tmp_path / "out")}.get(w, w) for w in words]
    res = runner.invoke(app, [*args[1:], "--no-plot"])
    assert res.exit_code == 0, res.output
    paired = (tmp_path / "out" / "paired.csv").read_text().splitlines()
    assert len(paired) > 1 and all(',"myopic",' in row for row in paired[1:])
    assert [p.name for p in (tmp_path / "out" / "jobs").glob("hub=*")] == ["hub=0"]


def test_against_outside_the_listed_methods_names_both_flags(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    args = ["evaluate", str(example_csv), "--methods", "greedy", "--against", "myopic"]
    fails_cleanly([*args, "--out", str(tmp_path / "out")], tmp_path, "--against", "--methods")


def test_a_split_day_with_nothing_to_plan_is_left_out_and_a_named_one_refused(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """One delivery past midnight after the file's last day makes that day part of the
    test split with nothing due in service hours: the split leaves it out with a warning
    naming it; asked for by --dates it is one line naming the day, before any replay
    runs or a job is kept (replay-day checks its days the same way)."""
    import pyarrow.parquet as pq

    data = tmp_path / "straggler.csv"
    row = "999999,1,Shanghai,7,121.34,31.13,1,2,08-12 23:50:00,,,,08-13 00:20:00,,,,813"
    data.write_text(example_csv.read_text(encoding="utf-8") + row + "\n", encoding="utf-8")
    args = ["evaluate", "--area", "square", str(data), "--methods", "ops-global"]
    args += ["--workers", "1", "--no-plot"]
    named = [*args, "--dates", "0812,0813", "--out", str(tmp_path / "named")]
    fails_cleanly(named, tmp_path, "no requests on 2022-08-13")
    main = "from marops_cli.cli.app import main; main()"
    cmd = [sys.executable, "-c", main, *args, "--out", str(tmp_path / "split")]
    res = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "warning: left out 2022-08-13 of the test split: nothing due" in res.stderr
    days = set(pq.read_table(tmp_path / "split" / "results.parquet").column("day").to_pylist())
    assert days and "2022-08-13" not in {str(d) for d in days}

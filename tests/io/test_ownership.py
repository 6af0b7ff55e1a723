"""Which files marops replaces: its own by provenance (metadata or the journal), never a
user's file by its name, never one of the run's inputs (docs/outputs.md)."""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from marops_cli.errors import InputError
from marops_cli.io import output_set
from marops_cli.io.ownership import (
    JOURNAL,
    check_outputs,
    check_replaceable,
    register_inputs,
    replacing_foreign_files,
    written_by_marops,
)

MAIN = "from marops_cli.cli.app import main; main()"


def marops(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """The real command line in a process of its own."""
    cmd = [sys.executable, "-c", MAIN, *map(str, args)]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=cwd, timeout=300)


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_a_hand_written_depots_file_is_not_marops_own(tmp_path: Path) -> None:
    """docs/outputs.md lets an analyst write depots by hand: the same "depots" and
    "frame" keys as marops' file, without marops' "meta". Only the meta (or the
    journal) makes it marops' own, so ``segment --out`` never replaces it unasked."""
    doc = {
        "frame": {"lng0": 121.4, "lat0": 31.2, "size_km": 10.0},
        "depots": [{"id": 0, "x_m": 0.0, "y_m": 0.0}, {"id": 1, "x_m": 900.0, "y_m": 0.0}],
        "candidates": {"0": [0, 1], "1": [1, 0]},
    }
    path = tmp_path / "my_depots.json"
    path.write_text(json.dumps(doc))
    assert not written_by_marops(path)
    path.write_text(json.dumps({"meta": {"package": "marops", "version": "x"}, **doc}))
    assert written_by_marops(path)


def test_a_json_file_past_the_small_file_cap_is_judged_by_its_head_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An unlisted JSON file is judged by its content. One larger than the small inputs'
    cap (a busy day's stops.json is) is judged by its first member, read from the file's
    first bytes, never loaded whole into memory: marops' own, whose "meta" (or a
    GeoJSON's "marops" after its "type") comes first, is marops's; a file whose "meta"
    lies past those bytes is not (it is kept)."""
    import marops_cli.io.ownership as ownership
    import marops_cli.io.routejson as routejson

    path = tmp_path / "stops.json"
    path.write_text(json.dumps({"meta": {"package": "marops"}, "stops": ["x" * 4096]}))
    geo = tmp_path / "routes.GeoJSON"  # a suffix in capitals is a GeoJSON all the same
    geo.write_text(
        json.dumps({"type": "FeatureCollection", "marops": {"package": "marops"}, "f": "x" * 4096})
    )
    late = tmp_path / "metrics.json"
    late.write_text(json.dumps({"pad": "x" * 4096, "meta": {"package": "marops"}}))
    assert written_by_marops(path) and written_by_marops(geo) and written_by_marops(late)
    for module in (ownership, routejson):
        monkeypatch.setattr(module, "MAX_SMALL_FILE", 1024)
    monkeypatch.setattr(routejson, "HEAD_BYTES", 256)
    assert written_by_marops(path) and written_by_marops(geo)
    assert not written_by_marops(late)
    path.write_text(json.dumps({"meta": {"package": "marops", "pad": "x" * 512}, "s": "x" * 4096}))
    assert not written_by_marops(path)  # its meta is cut by the bytes read


def test_a_depots_file_edited_by_hand_is_not_replaced_unasked(tmp_path: Path) -> None:
    """A depots file marops wrote and an analyst then edited keeps marops' ``meta``:
    the journal, not the meta, says whose content it holds, so ``segment --out`` asks
    for ``--force`` instead of dropping the edit."""
    data = tmp_path / "city.csv"
    assert marops("synth", "--days", "2", "--orders-per-day", "80", "--out", data).returncode == 0
    out = tmp_path / "depots.json"
    args = ("segment", data, "--n-depots", "4", "--out", out)
    assert marops(*args).returncode == 0
    assert out.name in json.loads((tmp_path / JOURNAL).read_text())["files"]
    assert marops(*args).returncode == 0  # marops's own: replaced without --force
    doc = json.loads(out.read_text())
    doc["depots"][0]["x_m"] += 100.0
    edited = json.dumps(doc)
    out.write_text(edited)
    assert doc["meta"]["package"] == "marops" and not written_by_marops(out)
    res = marops(*args)
    assert res.returncode == 2
    assert one_line(res.stderr) == (
        f"marops: error: {out}: exists and was not written by marops; pass --force to replace it"
    )
    assert out.read_text() == edited
    assert marops(*args, "--force").returncode == 0
    assert written_by_marops(out)


# -- failure 3: synth replaced a user's file judged by its extension -------------------
def test_synth_never_replaces_a_file_marops_did_not_write(tmp_path: Path) -> None:
    notes = tmp_path / "analyst_notes.csv"
    notes.write_text("my notes, not data\n")
    res = marops("synth", "--days", "1", "--orders-per-day", "50", "--out", notes)
    assert res.returncode == 2
    assert one_line(res.stderr) == (
        f"marops: error: {notes}: exists and was not written by marops; pass --force to replace it"
    )
    assert notes.read_text() == "my notes, not data\n"


def test_synth_replaces_its_own_file_until_someone_edits_it(tmp_path: Path) -> None:
    data = tmp_path / "city.csv"
    args = ("synth", "--days", "1", "--orders-per-day", "50", "--out", data)
    assert marops(*args).returncode == 0
    assert data.name in json.loads((tmp_path / JOURNAL).read_text())["files"]
    assert marops(*args).returncode == 0  # the journal says it is marops's
    with data.open("a") as fh:
        fh.write("an analyst's extra line\n")
    res = marops(*args)
    assert res.returncode == 2 and "not written by marops" in res.stderr
    assert data.read_text().endswith("an analyst's extra line\n")


def test_synth_replaces_its_own_parquet_file(tmp_path: Path) -> None:
    """synth's Parquet carries no marops metadata (a reader cannot tell it from an
    export): the journal records it, so the same command runs again without --force."""
    data = tmp_path / "city.parquet"
    args = ("synth", "--days", "1", "--orders-per-day", "50", "--out", data)
    assert marops(*args).returncode == 0
    assert data.name in json.loads((tmp_path / JOURNAL).read_text())["files"]
    res = marops(*args)
    assert res.returncode == 0, res.stderr
    assert written_by_marops(data)


def test_synth_parquet_keeps_a_foreign_journal_name(tmp_path: Path) -> None:
    """A file by the journal's name that is no journal stops synth's Parquet as it
    stops its CSV: recording the data would replace it."""
    from marops_cli.app.synth import synth

    (tmp_path / JOURNAL).write_text("my own file\n")
    with pytest.raises(InputError, match="is not the journal marops keeps"):
        synth(days=1, orders_per_day=50, out=tmp_path / "city.parquet")
    assert (tmp_path / JOURNAL).read_text() == "my own file\n"
    assert not (tmp_path / "city.parquet").exists()


def test_a_figure_is_marops_s_only_while_the_journal_holds_its_content(tmp_path: Path) -> None:
    fig = tmp_path / "alpha.png"
    fig.write_bytes(b"\x89PNG a user's figure")
    assert not written_by_marops(fig)  # the name and extension say nothing
    with replacing_foreign_files(True), output_set() as files:
        files.write_bytes(fig, b"\x89PNG marops's figure")
    assert written_by_marops(fig)
    with output_set() as files:  # replaced again without --force
        files.write_bytes(fig, b"\x89PNG the next run's figure")
    assert written_by_marops(fig)
    fig.write_bytes(b"\x89PNG edited")
    assert not written_by_marops(fig)
    with pytest.raises(InputError, match="not written by marops"):
        check_replaceable([fig])


def test_the_journal_drops_files_that_are_gone(tmp_path: Path) -> None:
    with output_set() as files:
        files.write_bytes(tmp_path / "a.csv", b"a")
        files.write_bytes(tmp_path / "b.md", b"b")
    (tmp_path / "a.csv").unlink()
    with output_set() as files:
        files.write_bytes(tmp_path / "b.md", b"bb")
    listed = json.loads((tmp_path / JOURNAL).read_text())["files"]
    assert set(listed) == {"b.md"}


# -- failure 2: evaluate wrote its paired table over its data file ---------------------
def test_evaluate_refuses_an_input_named_like_one_of_its_outputs(
    example_csv: Path, tmp_path: Path
) -> None:
    ev = tmp_path / "ev"
    ev.mkdir()
    data = ev / "paired.csv"
    shutil.copy(example_csv, data)
    before = data.read_bytes()
    res = marops("evaluate", data, "--dates", "0811", "--against", "stay", "--out", ev)
    assert res.returncode == 2
    assert "is an input of this run" in one_line(res.stderr)
    assert data.read_bytes() == before
    assert sorted(p.name for p in ev.iterdir()) == ["paired.csv"]


@pytest.mark.parametrize("link", ["symlink", "hardlink", "dotdot"])
def test_no_output_replaces_an_input_reached_another_way(tmp_path: Path, link: str) -> None:
    data = tmp_path / "data.csv"
    data.write_text("order_id\n1\n")
    out = tmp_path / "out"
    out.mkdir()
    target = out / "summary.csv"
    if link == "symlink":
        target.symlink_to(data)
    elif link == "hardlink":
        os.link(data, target)
    else:
        target = out / ".." / "data.csv"
    with replacing_foreign_files(True):  # even --force never writes over an input
        register_inputs([data])
        with pytest.raises(InputError, match="is an input of this run"), output_set() as f:
            f.write_bytes(target, b"results")
    assert data.read_text() == "order_id\n1\n"
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


def test_a_symlink_to_a_marops_file_is_the_user_s(example_csv: Path, tmp_path: Path) -> None:
    """A user's link at an output's name (``latest.json -> target.json``) was replaced by
    a plain file when it led to a file marops wrote: a link is never marops's, so it is
    refused without --force, its target read by no one and kept."""
    target = tmp_path / "target.json"
    target.write_text(json.dumps({"meta": {"package": "marops"}}))
    assert written_by_marops(target)
    link = tmp_path / "latest.json"
    link.symlink_to("target.json")
    with pytest.raises(InputError, match="latest.json: exists and was not written by marops"):
        check_replaceable([link])
    args = ["segment", example_csv, "--dates", "0809..0810", "--out", link]
    res = marops(*args)
    assert res.returncode == 2 and "pass --force" in one_line(res.stderr)
    assert link.is_symlink() and json.loads(target.read_text())["meta"] == {"package": "marops"}
    assert marops(*args, "--force").returncode == 0
    assert not link.is_symlink() and json.loads(target.read_text())["meta"] == {"package": "marops"}


def test_a_broken_journal_makes_nothing_marops_s(tmp_path: Path) -> None:
    fig = tmp_path / "routes.png"
    with output_set() as files:
        files.write_bytes(fig, b"\x89PNG")
    for text in ("[1, 2]", "not json", '{"format": "marops-files/1", "files": []}'):
        (tmp_path / JOURNAL).write_text(text)
        assert not written_by_marops(fig)


def test_a_dangling_symlink_is_never_marops_s(tmp_path: Path) -> None:
    """A dangling symlink where an output goes is someone else's: refused without
    --force."""
    target = tmp_path / "stops.parquet"
    target.symlink_to(tmp_path / "nowhere")
    with pytest.raises(InputError, match="stops.parquet: exists and was not written by marops"):
        check_replaceable([target])
    with replacing_foreign_files(True):
        check_replaceable([target])
    assert os.path.lexists(target)


def test_a_pipe_where_an_output_goes_is_refused_even_with_force(tmp_path: Path) -> None:
    """A named pipe (or a device) is no file to replace: refused with --force too, and
    judged without opening it (a pipe would block the read)."""
    target = tmp_path / "stops.parquet"
    os.mkfifo(target)
    for force in (False, True):
        with replacing_foreign_files(force), pytest.raises(InputError, match="is a pipe"):
            check_replaceable([target])
    assert stat.S_ISFIFO(os.lstat(target).st_mode)


def test_a_folder_or_a_loop_where_a_file_goes_is_refused_before_the_work(tmp_path: Path) -> None:
    """A folder named like the output would fail the final rename after the work; a
    loop of symbolic links would fail with a traceback: both are one line up front."""
    (tmp_path / "stops.parquet").mkdir()
    with replacing_foreign_files(True), pytest.raises(InputError, match="is a folder"):
        check_replaceable([tmp_path / "stops.parquet"])
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    with pytest.raises(InputError, match="a/stops.parquet: cannot write"):
        check_replaceable([tmp_path / "a" / "stops.parquet"])
    with pytest.raises(InputError, match="cannot write .File name too long"):
        check_replaceable([tmp_path / ("x" * 300)])


def test_a_folder_to_make_whose_name_is_too_long_is_refused_before_the_work(
    tmp_path: Path,
) -> None:
    """A folder still to be made whose name the file system cannot take fails only when
    it is made: after the work, with the folders above it already made. It is refused
    up front, and nothing is made."""
    long = tmp_path / "new" / ("x" * 300)
    with pytest.raises(InputError, match="stops.parquet: cannot write .File name too long"):
        check_outputs([long / "stops.parquet"])
    deep = tmp_path / "new" / "/".join(["y" * 250] * 20)  # each name fits, the path does not
    with pytest.raises(InputError, match="cannot write .File name too long"):
        check_outputs([deep / "stops.parquet"])
    check_outputs([tmp_path / "new" / "a" / "b" / "stops.parquet"])  # names that fit
    assert list(tmp_path.iterdir()) == []


def test_a_path_whose_temporary_is_too_long_is_refused_before_the_work(
    tmp_path: Path,
) -> None:
    """The temporary ``.NAME.marops-XXXXXXXX.tmp`` is 21 bytes longer than the output: an
    output whose own name or path fits, but whose temporary's does not, failed only when
    written, after the work. Both limits count the temporary, and nothing is made."""
    name_max = os.pathconf(tmp_path, "PC_NAME_MAX")
    path_max = os.pathconf(tmp_path, "PC_PATH_MAX")
    with pytest.raises(InputError, match="cannot write .File name too long"):
        check_outputs([tmp_path / ("x" * (name_max - 10))])
    top = len(os.fsencode(tmp_path / "new")) + 1
    n, rest = divmod(path_max - 10 - top, 201)  # folders of 200 bytes and a slash each
    final = tmp_path / "new" / "/".join(["y" * 200] * n) / ("z" * max(rest - 1, 1))
    assert len(os.fsencode(final)) < path_max  # the output's path fits
    with pytest.raises(InputError, match="cannot write .File name too long"):
        check_outputs([final])
    assert list(tmp_path.iterdir()) == []


def test_plan_window_into_a_folder_whose_name_is_too_long_does_no_work(
    example_csv: Path, tmp_path: Path
) -> None:
    depots = tmp_path / "in" / "depots.json"
    assert marops("segment", example_csv, "--dates", "0801..0810", "--out", depots).returncode == 0
    out = tmp_path / "new" / ("x" * 300)
    res = marops(
        "plan-window",
        example_csv,
        "--depots",
        depots,
        "--date",
        "0811",
        "--window",
        "5",
        "--out",
        out,
    )
    assert res.returncode == 2
    assert one_line(res.stderr).endswith("stops.parquet: cannot write (File name too long)")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in"]


def test_a_path_too_long_to_look_up_is_bad_usage(tmp_path: Path) -> None:
    res = marops("segment", tmp_path / ("x" * 300 + ".csv"), "--out", tmp_path / "d.json")
    assert res.returncode == 2
    assert "File name too long" in one_line(res.stderr)


def test_a_small_input_that_is_a_pipe_never_blocks(tmp_path: Path) -> None:
    """A config, depots or fleet file that is a named pipe nobody writes to reads as
    nothing (one line), where a plain open would wait for ever; one with a writer reads."""
    from marops_cli.config import load_config
    from marops_cli.data.jsonfile import read_small_text

    pipe = tmp_path / "planner.toml"
    os.mkfifo(pipe)
    with pytest.raises(InputError, match="planner.toml: config file is a pipe .* nothing to read"):
        load_config(pipe)
    r, w = os.pipe()
    os.write(w, b"[sim]\ndrones = 3\n")
    os.close(w)
    try:
        assert read_small_text(f"/proc/self/fd/{r}", "config") == "[sim]\ndrones = 3\n"
    finally:
        os.close(r)


@pytest.mark.parametrize("command", ["replay-day", "plan-window"])
def test_no_output_replaces_a_file_of_the_actor_flown(
    example_csv: Path, tmp_path: Path, command: str
) -> None:
    """An actor's sidecar and weights are inputs of the run, whatever their names: an
    actor named like an output (``metrics``, ``stops``) in the output folder is refused,
    even with --force, and left as it was."""
    shipped = Path(__file__).resolve().parents[2] / "policies"
    out = tmp_path / "out"
    out.mkdir()
    name = "metrics" if command == "replay-day" else "stops"
    for suffix in (".safetensors", ".json"):
        shutil.copy(shipped / f"marops-ops{suffix}", out / f"{name}{suffix}")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    args = [command, example_csv, "--date", "0811", "--out", out, "--force"]
    if command == "plan-window":
        # refused before the depots are read: the file need not exist
        args += ["--window", "5", "--format", "json", "--depots", tmp_path / "depots.json"]
    res = marops(*args, "--policy", out / f"{name}.safetensors")
    assert res.returncode == 2, res.stderr
    said = one_line(res.stderr)
    assert "is an input of this run" in said and f"{name}.json" in said
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_a_day_folder_that_is_a_link_is_never_written_through(
    example_csv: Path, tmp_path: Path
) -> None:
    """Over several days each day's files of one study square go into ``OUT/<day>/``: a
    link there (to another run's day) is refused before any work, even with --force, its
    target kept."""
    other = tmp_path / "other" / "2022-08-11"
    other.mkdir(parents=True)
    (other / "metrics.json").write_text('{"mine": 1}')
    out = tmp_path / "out"
    out.mkdir()
    (out / "2022-08-11").symlink_to(other)
    res = marops(
        "replay-day", "--area", "square", example_csv, "--dates", "0811..0812", "--out", out,
        "--force", "--method", "stay", "--n-depots", "4",
    )  # fmt: skip
    assert res.returncode == 2
    assert "is a link" in one_line(res.stderr) and "2022-08-11" in res.stderr
    assert (other / "metrics.json").read_text() == '{"mine": 1}'
    assert sorted(p.name for p in out.iterdir()) == ["2022-08-11"]


def test_a_batch_of_outputs_reads_its_folder_s_journal_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Judging many files of one folder (clearing an earlier run's, checking a run's
    outputs) reads the folder's journal once, where it was read once a file (twice for a
    file the journal lists: whose it is, and that the journal is marops's); each file is
    judged as before."""
    import marops_cli.io.ownership as ownership
    from marops_cli.io.ownership import remove_ours

    names = [f"figure-{i}.png" for i in range(6)]
    with output_set() as files:
        for name in names:
            files.write_bytes(tmp_path / name, name.encode())
    (tmp_path / names[0]).write_bytes(b"edited")  # the user's now
    paths = [tmp_path / n for n in names]
    reads = []
    real = ownership.read_small_text

    def counted(path: object, what: str, limit: int | None = None) -> str:
        reads.append(Path(str(path)).name)
        return real(path, what, limit)

    monkeypatch.setattr(ownership, "read_small_text", counted)
    with pytest.raises(InputError, match="not written by marops"):
        check_replaceable(paths)
    assert reads == [JOURNAL]
    reads.clear()
    check_replaceable(paths[1:])
    check_outputs(paths[1:])
    assert reads == [JOURNAL, JOURNAL]
    reads.clear()
    remove_ours(paths)
    assert reads == [JOURNAL]
    assert sorted(p.name for p in tmp_path.iterdir()) == [JOURNAL, names[0]]
    reads.clear()
    assert not written_by_marops(paths[0]) and reads == [JOURNAL]

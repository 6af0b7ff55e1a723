"""An interrupted evaluation keeps what finished and resumes from it; --out is checked first."""

from __future__ import annotations

import datetime as dt
import json
import signal
from dataclasses import replace
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.config import PlannerConfig, override
from marops_cli.errors import InputError
from marops_cli.evaluate import evaluate_jobs, expand_settings, prepare
from marops_cli.evaluate.dataset import JobStore
from marops_cli.evaluate.runner import run, run_identity
from marops_cli.evaluate.tables import job_row, rows_table

DAYS = [dt.date(2022, 8, 11), dt.date(2022, 8, 12)]
WALL_TIME = ["runtime_s", "solver_solve_s"]  # the only columns that may differ between runs


@pytest.fixture(scope="module")
def prep(example_csv: Path):
    cfg = PlannerConfig()
    cfg.data.area = "square"
    return prepare(example_csv, cfg, ["stay", "greedy"], expand_settings(cfg), days=DAYS)


def test_interrupted_run_resumes_to_the_same_rows(prep, tmp_path: Path) -> None:
    full = evaluate_jobs(prep, workers=1).results
    store = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    store.open()

    def stop_after_two(done: int, total: int, job) -> None:
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run(prep, workers=1, on_result=stop_after_two, sink=store)
    files = sorted((tmp_path / "jobs").rglob("*.parquet"))
    assert len(files) == 2 and store.finished() == {0, 1}  # written as each job finished
    assert files[0].relative_to(tmp_path).parts[:4] == (
        "jobs",
        "hub=0",
        "method=stay",
        "day=2022-08-11",
    )
    ran: list[int] = []
    again = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    again.open()
    assert again.resumed == 2
    rows = evaluate_jobs(prep, 1, lambda d, t, job: ran.append(job.index), again).results
    assert sorted(ran) == [2, 3]  # only the rest ran
    assert rows.drop_columns(WALL_TIME).equals(full.drop_columns(WALL_TIME), check_metadata=True)
    assert rows.schema == full.schema


def test_jobs_of_another_run_are_refused_and_force_clears_them(prep, tmp_path: Path) -> None:
    jobs = tmp_path / "jobs"
    (jobs / "hub=0").mkdir(parents=True)
    (jobs / "_identity.json").write_text(json.dumps({"identity": "another run"}))
    with pytest.raises(InputError, match="other settings"):
        JobStore(jobs, prep, run_identity(prep)).open()
    store = JobStore(jobs, prep, run_identity(prep))
    store.open(force=True)
    assert store.finished() == set() and (jobs / "hub=0").is_dir()  # nothing goes yet
    store.add(prep.jobs[2], {"mean_energy_kj": 1.5, "delivered": 3})
    assert json.loads((jobs / "_identity.json").read_text())["identity"] == run_identity(prep)
    assert list(jobs.rglob("*.parquet")) == [store.path(prep.jobs[2])]


def test_force_deletes_only_the_replays_marops_wrote(prep, tmp_path: Path) -> None:
    # Another run's jobs (one replay written by marops) and a user's note beside them.
    jobs = tmp_path / "jobs"
    first = JobStore(jobs, prep, "another run")
    first.open()
    first.add(prep.jobs[0], {"mean_energy_kj": 1.0, "delivered": 1})
    note = jobs / "notes" / "mine.txt"
    note.parent.mkdir()
    note.write_text("mine")
    # The note lies among the jobs: refused, with or without --force, and kept.
    for force in (False, True):
        with pytest.raises(InputError, match="not written by marops evaluate") as err:
            JobStore(jobs, prep, run_identity(prep)).open(force=force)
        assert err.value.file == str(note)
    note.rename(tmp_path / "mine.txt")
    store = JobStore(jobs, prep, run_identity(prep))
    store.open(force=True)
    store.add(prep.jobs[2], {"mean_energy_kj": 1.5, "delivered": 3})
    # The other run's replay is gone with the folders it leaves empty; this run's is
    # there, and the user's (now empty) folder stays.
    assert sorted(p.relative_to(jobs) for p in jobs.rglob("*") if p.is_file()) == [
        Path("_identity.json"),
        store.path(prep.jobs[2]).relative_to(jobs),
    ]
    assert (jobs / "notes").is_dir() and (tmp_path / "mine.txt").read_text() == "mine"


def test_a_link_among_the_jobs_is_refused_and_its_target_kept(prep, tmp_path: Path) -> None:
    """A folder or file among the jobs that is a link (to another evaluation's jobs) is
    never written through: refused like any file marops did not write there."""
    other = JobStore(tmp_path / "other", prep, run_identity(prep))
    other.open()
    other.add(prep.jobs[0], {"mean_energy_kj": 1.0, "delivered": 1})
    kept = other.path(prep.jobs[0]).read_bytes()
    jobs = tmp_path / "jobs"
    mine = JobStore(jobs, prep, run_identity(prep))
    mine.open()
    mine.add(prep.jobs[1], {"mean_energy_kj": 2.0, "delivered": 2})
    link = jobs / "hub=0" / "method=stay"
    for p in link.rglob("*.parquet"):
        p.unlink()
    for d in sorted(link.rglob("*"), reverse=True):
        d.rmdir()
    link.rmdir()
    link.symlink_to(tmp_path / "other" / "hub=0" / "method=stay")
    for force in (False, True):
        with pytest.raises(InputError, match="not written by marops evaluate") as err:
            JobStore(jobs, prep, run_identity(prep)).open(force=force)
        assert err.value.file == str(link)
    assert other.path(prep.jobs[0]).read_bytes() == kept
    # The jobs folder itself a link to the other evaluation's: refused, nothing cleared.
    linked = tmp_path / "linked"
    linked.symlink_to(tmp_path / "other")
    for force in (False, True):
        with pytest.raises(InputError, match="is a link; the jobs folder") as err:
            JobStore(linked, prep, "a third run").open(force=force)
        assert err.value.file == str(linked)
    assert other.path(prep.jobs[0]).read_bytes() == kept


def test_rows_read_back_are_the_rows_in_memory_and_a_damaged_file_runs_again(
    prep, tmp_path: Path
) -> None:
    store = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    store.open()
    ran = run(prep, workers=1, sink=store)
    # every value and type survives the files, wall times included
    in_memory = rows_table([job_row(prep, job, ran[job.index]) for job in prep.jobs])
    assert rows_table(store.rows()).equals(in_memory, check_metadata=True)
    damaged = store.path(prep.jobs[1])
    damaged.write_bytes(b"PAR1 cut short")  # not a file marops wrote: refused, kept
    again = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    with pytest.raises(InputError, match="not written by marops evaluate") as err:
        again.open()
    assert err.value.file == str(damaged) and damaged.read_bytes() == b"PAR1 cut short"
    damaged.unlink()
    again.open()
    assert again.finished() == {0, 2, 3}
    assert list(run(prep, workers=1, sink=again)) == [1]


def test_an_edited_job_file_runs_again_rather_than_feeding_the_tables(prep, tmp_path: Path) -> None:
    """A job file edited with its marops metadata kept: a metric turned to text, or a
    column dropped. Neither reaches the tables: the job counts as not done and runs
    again, to the same row."""
    store = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    store.open()
    ran = run(prep, workers=1, sink=store)
    want = rows_table([job_row(prep, job, ran[job.index]) for job in prep.jobs])
    for k, edit in ((1, "text"), (2, "dropped")):
        path = store.path(prep.jobs[k])
        table = pq.read_table(path)
        i = table.schema.get_field_index("avg_delay_h")
        if edit == "text":
            table = table.set_column(i, "avg_delay_h", pa.array(["x"]))
        else:
            table = table.remove_column(i)
        pq.write_table(table.replace_schema_metadata(table.schema.metadata), path)
    again = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    again.open()
    assert again.finished() == {0, 3}
    assert sorted(run(prep, workers=1, sink=again)) == [1, 2]
    got = rows_table(again.rows())
    for name in ("avg_delay_h", "mean_energy_kj", "delivered", "objective_j_mj"):
        assert got[name].equals(want[name]), name


def test_a_job_file_of_many_rows_runs_again_unread(prep, tmp_path: Path, monkeypatch) -> None:
    """A job's file holds one row; one of its row repeated (kept its metadata) is not
    read to find that out: a file of millions of repeated rows compresses to kilobytes
    and unpacks to gigabytes (5 million: 1.7 MB, 3.9 GB). Its footer tells; the job runs
    again, to the same row."""
    import numpy as np

    from marops_cli.evaluate import dataset

    store = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    store.open()
    ran = run(prep, workers=1, sink=store)
    want = rows_table([job_row(prep, job, ran[job.index]) for job in prep.jobs])
    path = store.path(prep.jobs[1])
    table = pq.read_table(path)
    many = table.take(pa.array(np.zeros(1000, dtype=np.int64)))
    pq.write_table(many.replace_schema_metadata(table.schema.metadata), path)
    read: list[Path] = []

    def recorded(p: Path, *args, **kwargs):
        read.append(Path(p))
        return dataset_read(p, *args, **kwargs)

    dataset_read = dataset.read_parquet
    monkeypatch.setattr(dataset, "read_parquet", recorded)
    again = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    again.open()
    assert again.finished() == {0, 2, 3} and path not in read
    assert sorted(run(prep, workers=1, sink=again)) == [1]
    got = rows_table(again.rows())
    assert got.drop_columns(WALL_TIME).equals(want.drop_columns(WALL_TIME))


def test_out_that_is_a_file_fails_before_any_work(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    out = tmp_path / "out"
    out.write_text("not a folder")
    args = ["evaluate", str(example_csv), "--methods", "stay", "--out", str(out)]
    fails_cleanly(args, tmp_path, "--out must be a folder")


@pytest.mark.parametrize("kind", ["file", "fifo", "link"])
def test_out_jobs_that_is_no_folder_fails_before_any_work(
    example_csv: Path, tmp_path: Path, fails_cleanly, kind: str
) -> None:
    """``OUT/jobs`` a file or a pipe (once ``Not a directory``, exit 1, after reading and
    segmenting), or a link: one line naming it, before any work, the file as it was."""
    import os

    out = tmp_path / "out"
    out.mkdir()
    jobs = out / "jobs"
    if kind == "file":
        jobs.write_text("mine")
    elif kind == "fifo":
        os.mkfifo(jobs)
    else:
        (tmp_path / "elsewhere").mkdir()
        jobs.symlink_to(tmp_path / "elsewhere")
    args = ["evaluate", str(example_csv), "--area", "square", "--dates", "0811"]
    args += ["--methods", "stay", "--workers", "1", "--no-plot", "--out", str(out)]
    said = "is a link" if kind == "link" else "is a file, not the folder where marops"
    fails_cleanly(args, tmp_path, f"{jobs}: {said}")
    assert kind != "file" or jobs.read_text() == "mine"


@pytest.mark.parametrize("where", [("jobs",), ("jobs", "hub=0"), ("jobs", "mine")])
def test_out_in_another_evaluations_jobs_folder_fails_before_any_work(
    prep, example_csv: Path, tmp_path: Path, fails_cleanly, where: tuple[str, ...]
) -> None:
    """An --out that is an evaluation's jobs folder, or a folder inside it, was taken:
    its tables and jobs went among that evaluation's jobs, which it then refused to
    resume or summarise. One line naming it, before any work, nothing written."""
    first = tmp_path / "first"
    store = JobStore(first / "jobs", prep, run_identity(prep))
    store.open()
    store.add(prep.jobs[0], {"mean_energy_kj": 1.0, "delivered": 1})
    out = first.joinpath(*where)
    args = ["evaluate", str(example_csv), "--area", "square", "--dates", "0811"]
    args += ["--methods", "stay", "--workers", "1", "--no-plot", "--out", str(out)]
    fails_cleanly(args, tmp_path, f"{out}: lies in the jobs folder of the evaluation in {first}")


@pytest.mark.parametrize(
    ("command", "name"),
    [
        (["segment"], "depots.json"),
        (["replay-day", "--date", "0811", "--method", "stay", "--area", "square"], "day"),
        (["train"], "a.pt"),
    ],
)
def test_other_commands_into_an_evaluations_jobs_folder_fail_before_any_work(
    prep, example_csv: Path, tmp_path: Path, fails_cleanly, command: list[str], name: str
) -> None:
    """segment, replay-day and train took an --out inside an evaluation's jobs folder,
    whose jobs that evaluation then refused to resume or summarise (a file it did not
    write among them); now one line naming it, before any work, nothing written."""
    first = tmp_path / "first"
    store = JobStore(first / "jobs", prep, run_identity(prep))
    store.open()
    store.add(prep.jobs[0], {"mean_energy_kj": 1.0, "delivered": 1})
    out = first / "jobs" / name
    args = [command[0], str(example_csv), *command[1:], "--out", str(out)]
    fails_cleanly(args, tmp_path, f"lies in the jobs folder of the evaluation in {first}")


def test_ctrl_c_exits_130_keeps_finished_jobs_and_prints_no_traceback(
    example_csv: Path, tmp_path: Path, stop_marops
) -> None:
    out = tmp_path / "ev"
    args = ["evaluate", "--area", "square", str(example_csv)]
    args += ["--methods", "stay,greedy,ops-random,myopic"]
    args += ["--dates", "0811..0812", "--workers", "2", "--no-plot", "--out", str(out)]
    jobs = out / "jobs"
    # Ctrl-C: the whole group, workers included
    code, err = stop_marops(args, lambda: any(jobs.rglob("*.parquet")), signal.SIGINT)
    assert code == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert "run the same command again to resume" in err
    # one line says it, the last: a script's `tail -1` keeps the hint
    said = [line for line in err.splitlines() if line.startswith("marops: interrupted")]
    assert len(said) == 1 and err.splitlines()[-1] == said[0], err
    kept = len(list(jobs.rglob("*.parquet")))
    assert kept >= 1 and not (out / "results.parquet").exists()
    assert f"{kept} of 8 replays are kept" in err
    # the same command resumes and finishes; the jobs stay beside the outputs
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    assert f"resumed: {kept} of 8 replays" in res.output
    assert (out / "results.parquet").is_file() and len(list(jobs.rglob("*.parquet"))) == 8


def test_jobs_of_another_run_are_refused_naming_what_differs(prep, tmp_path: Path) -> None:
    """A nightly job rerun with another flag is told which one, not only that one differs."""
    jobs = tmp_path / "jobs"
    first = JobStore(jobs, prep, run_identity(prep))
    first.open()
    first.add(prep.jobs[0], {"mean_energy_kj": 1.0, "delivered": 1})
    other = replace(
        prep,
        methods=["stay"],
        settings=[replace(prep.settings[0], alpha=0.3)],
        cfg=override(prep.cfg, sim__seed=4),
    )
    with pytest.raises(InputError) as err:
        JobStore(jobs, other, run_identity(other)).open()
    msg = err.value.message
    assert "--methods: stay, greedy there, stay here" in msg, msg
    assert "--alpha: 0.5 there, 0.3 here" in msg and "config sim.seed: 0 there, 4 here" in msg
    assert "--force" in msg and err.value.file == str(jobs)


def test_jobs_of_an_older_marops_run_are_refused_without_naming_a_difference(
    prep, tmp_path: Path
) -> None:
    jobs = tmp_path / "jobs"
    jobs.mkdir()
    (jobs / "_identity.json").write_text(json.dumps({"identity": "older", "jobs": 4}))
    with pytest.raises(InputError) as err:
        JobStore(jobs, prep, run_identity(prep)).open()
    assert err.value.message.startswith("holds the jobs of an evaluation with other settings;")


def test_force_clears_the_outputs_built_from_the_other_runs_jobs(prep, tmp_path: Path) -> None:
    """Another run's paired.csv or sweep figure would otherwise stay beside this run's
    tables as if it were this run's; a file of one's own by such a name stays."""
    from marops_cli.io import output_set

    out = tmp_path / "ev"
    jobs = out / "jobs"
    built = [out / n for n in ("results.parquet", "paired.csv", "alpha.png", "drones.png")]
    first = JobStore(jobs, prep, "another run", built=built)
    first.open()
    first.add(prep.jobs[0], {"mean_energy_kj": 1.0, "delivered": 1})
    with output_set() as files:  # that run's outputs, as marops writes them
        files.write_bytes(out / "paired.csv", b"against,method\n")
        files.write_bytes(out / "alpha.png", b"\x89PNG figure")
        files.write_with(out / "results.parquet", lambda p: pq.write_table(store_meta_table(), p))
    (out / "drones.png").write_bytes(b"a user's own figure")
    store = JobStore(jobs, prep, run_identity(prep), built=built)
    store.open(force=True)
    assert (out / "paired.csv").is_file()  # nothing goes before this run's first replay
    store.add(prep.jobs[1], {"mean_energy_kj": 1.5, "delivered": 3})
    left = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    assert left == ["drones.png", "jobs"]
    assert (out / "drones.png").read_bytes() == b"a user's own figure"


def store_meta_table() -> pa.Table:
    """A one-row table with marops metadata, as results.parquet carries."""
    return pa.table({"x": [1]}).replace_schema_metadata({b"marops": b'{"package": "marops"}'})


def test_a_folder_where_a_job_file_goes_is_refused_naming_it(prep, tmp_path: Path) -> None:
    """A folder at a job file's path (made by hand, or by another tool) is one line naming
    it before any job runs, not a system error when that job's file is written."""
    jobs = tmp_path / "jobs"
    first = JobStore(jobs, prep, run_identity(prep))
    first.open()
    first.add(prep.jobs[0], {"mean_energy_kj": 1.0, "delivered": 1, "avg_delay_h": 0.1})
    blocked = first.path(prep.jobs[1])
    (blocked / "inside").mkdir(parents=True)
    again = JobStore(jobs, prep, run_identity(prep))
    with pytest.raises(InputError) as err:
        again.open()
    assert err.value.file == str(blocked) and "is a folder where" in err.value.message
    assert (blocked / "inside").is_dir()  # left as it was


def test_a_job_file_with_a_metric_out_of_its_range_runs_again(prep, tmp_path: Path) -> None:
    """A job file whose metrics no replay writes (delivered_share NaN, a negative count, a
    negative day objective J: energy and priced delay), its marops metadata kept: its job
    runs again, to the same row, rather than feeding summary.csv and paired.csv."""
    store = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    store.open()
    ran = run(prep, workers=1, sink=store)
    want = rows_table([job_row(prep, job, ran[job.index]) for job in prep.jobs])
    edits = ((1, "delivered_share", float("nan")), (2, "undelivered", -3))
    for k, name, value in (*edits, (3, "objective_j_mj", -5.0)):
        path = store.path(prep.jobs[k])
        table = pq.read_table(path)
        i = table.schema.get_field_index(name)
        table = table.set_column(i, name, pa.array([value], table.schema.field(i).type))
        pq.write_table(table.replace_schema_metadata(table.schema.metadata), path)
    again = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    again.open()
    assert again.finished() == {0}
    assert sorted(run(prep, workers=1, sink=again)) == [1, 2, 3]
    got = rows_table(again.rows())
    for name in ("delivered_share", "undelivered", "delivered", "objective_j_mj"):
        assert got[name].equals(want[name]), name


@pytest.mark.parametrize("moved_to", ["day=2022-08-20", "method=myopic"])
def test_a_job_file_moved_under_another_partition_is_refused_naming_it(
    prep, tmp_path: Path, moved_to: str
) -> None:
    """A replay's file moved (or copied) under a day= or method= folder where none of
    the evaluation's jobs goes would be read from the dataset as one more row: refused,
    naming it and the replay it holds, and left where it is."""
    store = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    store.open()
    metrics = {"mean_energy_kj": 1.0, "avg_delay_h": 0.1, "delivered": 1, "requests": 2}
    store.add(prep.jobs[0], metrics)
    src = store.path(prep.jobs[0])
    key, _ = moved_to.split("=")
    parts = [moved_to if p.startswith(f"{key}=") else p for p in src.relative_to(store.root).parts]
    stray = store.root.joinpath(*parts)
    stray.parent.mkdir(parents=True)
    stray.write_bytes(src.read_bytes())
    again = JobStore(tmp_path / "jobs", prep, run_identity(prep))
    for force in (False, True):
        with pytest.raises(InputError) as err:
            again.open(force=force)
        assert err.value.file == str(stray)
        assert "where no replay of this evaluation goes" in err.value.message
        assert "hub=0/method=stay/day=2022-08-11/s0-r0.parquet" in err.value.message
    assert stray.read_bytes() == src.read_bytes()
    stray.unlink()
    again.open()
    assert again.finished() == {0}


def test_force_leaves_a_user_file_named_like_a_temporary_below_out(prep, tmp_path: Path) -> None:
    """Only the temporaries a run recorded in its folder's lock are ever removed: a user's
    file below --out named as marops names one (here in a job's folder, where this run
    writes under its lock) stays, --force or not (docs/outputs.md, "Temporaries")."""
    from marops_cli.io.atomic import folder_lock

    out = tmp_path / "ev"
    first = JobStore(out / "jobs", prep, "another run")
    first.open()
    first.add(prep.jobs[0], {"mean_energy_kj": 1.0, "delivered": 1, "requests": 2})
    mine = first.path(prep.jobs[0]).parent / ".s0-r0.parquet.marops-12345678.tmp"
    mine.write_bytes(b"a user's file")
    with folder_lock(out):
        store = JobStore(out / "jobs", prep, run_identity(prep))
        store.open(force=True)
        store.add(prep.jobs[0], {"mean_energy_kj": 1.5, "delivered": 3, "requests": 4})
    assert mine.read_bytes() == b"a user's file"
    assert store.path(prep.jobs[0]).is_file()

"""The evaluate use case of the application layer: a table in, tables out, progress told."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import pytest

from marops_cli.app.evaluate import EvaluateConfig, evaluate
from marops_cli.config import PlannerConfig
from marops_cli.data.reader import read_lade

DAY = dt.date(2022, 8, 11)
WALL_TIME = ["runtime_s", "solver_solve_s"]  # the only columns that may differ between runs


def _square() -> PlannerConfig:
    """The settings of one study square (the use case over a city: tests/segment/)."""
    cfg = PlannerConfig()
    cfg.data.area = "square"
    return cfg


class Told:
    """A progress that keeps what it is told."""

    def __init__(self) -> None:
        self.messages: list[str] = []
        self.steps: list[tuple[str, int, str]] = []
        self.advances: list[str] = []
        self.finished = 0

    def message(self, text: str) -> None:
        self.messages.append(text)

    def warning(self, text: str) -> None:
        raise AssertionError(text)

    def start(self, label: str, total: int, unit: str) -> None:
        self.steps.append((label, total, unit))

    def advance(self, text: str = "") -> None:
        self.advances.append(text)

    def finish(self) -> None:
        self.finished += 1


@pytest.fixture(scope="module")
def in_memory(example_csv: Path):
    cfg = _square()
    table = read_lade(example_csv, cfg.data)
    told = Told()
    config = EvaluateConfig(cfg, ["stay", "greedy"], days=[DAY], workers=1, against="stay")
    return evaluate(table, config, progress=told), told


def test_a_table_in_memory_gives_tables_and_writes_nothing(in_memory) -> None:
    res, told = in_memory
    assert res.files == [] and res.folder is None and res.days == [DAY]
    assert res.results.num_rows == 2 and res.summary.num_rows == 2
    assert res.results.column("method").to_pylist() == ["stay", "greedy"]
    assert res.paired is not None and set(res.paired.column("method").to_pylist()) == {"greedy"}
    assert told.messages[0].startswith("shanghai_synth.csv: 22,043 rows read")
    # counted as read: "1 setting", not "1 settings"
    want = "evaluate: 2 methods x 1 setting x 1 day x 1 repeat = 2 replays, on 1 worker"
    assert told.messages[1] == want, told.messages[1]
    assert told.steps == [("evaluate", 2, "replays")] and told.finished == 1
    assert [a.split(":")[0] for a in told.advances] == ["evaluate 1/2", "evaluate 2/2"]


def test_a_folder_gets_the_same_rows_and_the_files(
    in_memory, example_csv: Path, tmp_path: Path
) -> None:
    res, _ = in_memory
    config = EvaluateConfig(_square(), ["stay", "greedy"], days=[DAY], workers=1)
    again = evaluate(example_csv, config, out=tmp_path, progress=Told())
    assert again.folder == tmp_path and again.paired is None
    assert [p.name for p in again.files][:3] == ["results.parquet", "summary.csv", "summary.md"]
    assert all(p.is_file() for p in again.files) and (tmp_path / "jobs").is_dir()
    assert again.results.drop(WALL_TIME).equals(res.results.drop(WALL_TIME))
    told = Told()  # a second run finds every job done: each is counted, none is run
    evaluate(example_csv, config, out=tmp_path, progress=told)
    assert told.messages[2] == f"resumed: 2 of 2 replays from {tmp_path / 'jobs'}"
    assert told.advances == ["", ""]


def test_a_run_stopped_before_any_replay_says_nothing_is_kept(
    example_csv: Path, tmp_path: Path
) -> None:
    """Not "0 of 2 replays are kept in OUT/jobs", a folder that is not left behind."""

    class StoppedAtOnce(Told):
        def start(self, label: str, total: int, unit: str) -> None:
            raise KeyboardInterrupt

    out = tmp_path / "ev"
    config = EvaluateConfig(_square(), ["stay", "greedy"], days=[DAY], workers=1)
    with pytest.raises(KeyboardInterrupt) as stop:
        evaluate(example_csv, config, out=out, progress=StoppedAtOnce())
    assert stop.value.__notes__ == ["no replay of 2 had finished: nothing is kept"]
    assert not out.exists()

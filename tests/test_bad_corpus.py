"""Every file of the bad-input corpus through every command that reads it: exit 2, one
line naming the file, no traceback, nothing written, the input unchanged."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app

from .bad_corpus import KINDS, NEEDLES, write_corpus

E = "0811"


def _commands(kind: str, bad: Path, ok: dict[str, Path], out: Path) -> dict[str, list[str]]:
    data, depots = str(ok["data"]), str(ok["depots"])
    if kind == "data":
        d = str(bad)
        return {
            "segment": [
                "segment",
                d,
                "--n-depots",
                "1",
                "--dates",
                E,
                "--out",
                str(out / "d.json"),
            ],
            "replay-day": ["replay-day", d, "--date", E, "--method", "stay", "--out", str(out)],
            "plan-window": ["plan-window", d, "--depots", depots, "--date", E, "--window", "1"]
            + ["--out", str(out)],
            "evaluate": ["evaluate", d, "--methods", "stay", "--dates", E, "--out", str(out)],
            "train": ["train", d, "--episodes", "1", "--out", str(out / "a.pt")],
        }
    if kind == "config":
        c = ["--config", str(bad)]
        return {
            "segment": ["segment", data, "--out", str(out / "d.json"), *c],
            "replay-day": [
                "replay-day",
                data,
                "--date",
                E,
                "--method",
                "stay",
                "--out",
                str(out),
                *c,
            ],
            "evaluate": [
                "evaluate",
                data,
                "--methods",
                "stay",
                "--dates",
                E,
                "--out",
                str(out),
                *c,
            ],
        }
    if kind == "depots":
        return {
            "replay-day": [
                "replay-day",
                data,
                "--date",
                E,
                "--method",
                "stay",
                "--depots",
                str(bad),
            ]
            + ["--out", str(out)],
            "plan-window": ["plan-window", data, "--depots", str(bad), "--date", E, "--window", "1"]
            + ["--out", str(out)],
        }
    if kind == "policy":
        # Under the paper's operating model, which the recurrent actor is trained for: the
        # file itself is judged, not the model it was made for.
        p, paper = str(bad), ["--config", str(Path(data).parent / "paper.toml")]
        return {
            "replay-day": ["replay-day", data, "--date", E, "--method", "marops", "--policy", p]
            + ["--out", str(out), *paper],
            "evaluate": ["evaluate", data, "--methods", "marops", "--policy", p, "--dates", E]
            + ["--out", str(out), *paper],
        }
    assert kind == "fleet"
    return {
        "plan-window": ["plan-window", data, "--depots", depots, "--date", E, "--window", "1"]
        + ["--fleet", str(bad), "--out", str(out)],
    }


CASES = [
    (kind, name, cmd)
    for kind, files in KINDS.items()
    for name in files
    for cmd in _commands(kind, Path(name), {"data": Path("d"), "depots": Path("p")}, Path("o"))
]


@pytest.fixture(scope="module")
def corpus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Path]]:
    return write_corpus(tmp_path_factory.mktemp("bad"))


@pytest.fixture(scope="module")
def good(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    depots = tmp_path_factory.mktemp("good") / "depots.json"
    res = CliRunner().invoke(app, ["segment", str(example_csv), "--out", str(depots)])
    assert res.exit_code == 0, res.output
    return {"data": example_csv, "depots": depots}


def _hashes(folder: Path) -> dict[Path, str]:
    return {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.rglob("*") if p.is_file()}


def test_the_corpus_is_large_enough() -> None:
    assert sum(len(files) for files in KINDS.values()) >= 50
    assert len(CASES) >= 100


@pytest.mark.parametrize(("kind", "name", "cmd"), CASES, ids=[f"{k}/{n}/{c}" for k, n, c in CASES])
def test_bad_input(corpus, good, tmp_path: Path, fails_cleanly, kind: str, name: str, cmd: str):
    bad = corpus[kind][name]
    before = _hashes(bad.parent)
    out = tmp_path / "out"
    args = _commands(kind, bad, good, out)[cmd]
    # The one line names the culprit: the bad file, or the day the data lacks.
    line = fails_cleanly(args, tmp_path)
    assert len(line) < 2_000, line[:300]  # a file's value quoted in it is cut short
    named = bad.name in line or bad.with_suffix(".json").name in line
    assert named or (kind == "data" and "2022-08-11" in line), line
    needles = NEEDLES.get(name, "")
    assert any(n in line for n in ((needles,) if isinstance(needles, str) else needles)), line
    assert _hashes(bad.parent) == before
    assert not out.exists()

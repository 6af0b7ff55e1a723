"""No command overwrites one of its inputs: exit 2, one line, the input unchanged."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def inputs(example_csv: Path, tmp_path: Path, depots_json: Path) -> dict[str, Path]:
    data = tmp_path / "data.csv"
    shutil.copy(example_csv, data)
    cfg = tmp_path / "planner.json"  # a config with an unusual name
    cfg.write_text("[plan]\nalpha = 0.5\n")
    day = tmp_path / "day"
    day.mkdir()
    depots = day / "metrics.json"  # a depots file where replay-day writes its metrics
    shutil.copy(depots_json, depots)
    return {"data": data, "config": cfg, "depots": depots}


@pytest.fixture(scope="module")
def depots_json(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    out = tmp_path_factory.mktemp("dep") / "depots.json"
    res = CliRunner().invoke(app, ["segment", str(example_csv), "--out", str(out)])
    assert res.exit_code == 0, res.output
    return out


CASES = {
    "segment --out DATA": lambda p: ["segment", str(p["data"]), "--out", str(p["data"])],
    "segment --out CONFIG": lambda p: [
        "segment",
        str(p["data"]),
        "--out",
        str(p["config"]),
        "--config",
        str(p["config"]),
    ],
    "plan-window --out DATA": lambda p: [
        "plan-window",
        str(p["data"]),
        "--depots",
        str(p["depots"]),
        "--date",
        "0811",
        "--window",
        "3",
        "--out",
        str(p["data"]),
    ],
    "replay-day over its depots file": lambda p: [
        "replay-day",
        str(p["data"]),
        "--date",
        "0811",
        "--depots",
        str(p["depots"]),
        "--out",
        str(p["depots"].parent),
    ],
    "train --out DATA": lambda p: ["train", str(p["data"]), "--out", str(p["data"])],
}


@pytest.mark.parametrize("case", list(CASES))
def test_an_input_is_never_overwritten(inputs, case: str, fails_cleanly) -> None:
    before = {k: _sha(v) for k, v in inputs.items()}
    args = CASES[case](inputs)
    fails_cleanly(args, inputs["data"].parent)
    assert {k: _sha(v) for k, v in inputs.items()} == before


def test_a_file_marops_did_not_write_is_replaced_only_with_force(
    example_csv: Path, tmp_path: Path
) -> None:
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    out = tmp_path / "depots.json"
    out.write_text('{"notes": "an analyst\'s own file"}')
    args = ["segment", str(example_csv), "--out", str(out)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2
    assert "depots.json: exists and was not written by marops; pass --force" in res.stderr
    assert out.read_text() == '{"notes": "an analyst\'s own file"}'
    assert not list(tmp_path.glob(".*.tmp"))
    assert CliRunner().invoke(app, [*args, "--force"]).exit_code == 0
    assert CliRunner().invoke(app, args).exit_code == 0  # now ours: replaced freely


def test_the_file_on_standard_input_is_never_overwritten(example_csv: Path, tmp_path: Path) -> None:
    """``marops segment - --out F --force < F``: standard input's file is an input of the
    run (told by device and inode, its name being unknown), so no output replaces it."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    data = tmp_path / "data.json"  # a data file under an output's name
    shutil.copy(example_csv, data)
    before = _sha(data)
    code = (
        f"import sys; sys.path.insert(0, {str(root)!r}); "
        "from marops_cli.cli.app import main; main()"
    )
    with data.open("rb") as stdin:
        res = subprocess.run(
            [sys.executable, "-c", code, "segment", "-", "--out", str(data), "--force"],
            cwd=tmp_path,
            stdin=stdin,
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert res.returncode == 2, res.stderr
    assert "data.json: is an input of this run (standard input)" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert _sha(data) == before

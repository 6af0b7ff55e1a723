"""Two options on one command line of which one would override the other unsaid
(``--drones`` and ``--fleet``, ``--n-depots`` and ``--depots``, ``--config`` twice) are
one usage error naming both, before any work; a value from the environment or a config
file under an option stays the documented precedence."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def run(args: list[str], cwd: Path, **env: str) -> subprocess.CompletedProcess[str]:
    """This checkout's ``marops ARGS`` in a process of its own."""
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r}); "
        "from marops_cli.cli.app import main; main()"
    )
    return subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=cwd,
        env={**os.environ, "MAROPS_PLAIN": "1", **env},
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture
def files(tmp_path: Path) -> Path:
    (tmp_path / "fleet.toml").write_text("[counts]\ndefault = 3\n")
    (tmp_path / "a.toml").write_text("[plan]\nalpha = 0.3\n")
    (tmp_path / "b.toml").write_text("[sim]\ndrones = 4\n")
    return tmp_path


CASES = {
    "replay-drones-fleet": (
        ["replay-day", "{data}", "--date", "0811", "--drones", "4", "--fleet", "fleet.toml"],
        ("--drones", "--fleet"),
    ),
    "plan-window-drones-fleet": (
        ["plan-window", "{data}", "--depots", "d.json", "--date", "0811", "--window", "3"]
        + ["--fleet", "fleet.toml", "--drones", "4"],
        ("--drones", "--fleet"),
    ),
    "replay-n-depots-depots": (
        ["replay-day", "{data}", "--date", "0811", "--depots", "d.json", "--n-depots", "4"],
        ("--n-depots", "--depots"),
    ),
    "replay-segment-depots": (
        ["replay-day", "{data}", "--date", "0811", "--segment", "squares", "--depots", "d.json"],
        ("--segment", "--depots"),
    ),
    "replay-area-hubs-depots": (
        ["replay-day", "{data}", "--date", "0811", "--area", "hubs", "--depots", "d.json"],
        ("--area hubs", "--depots"),
    ),
    "replay-area-hubs-fleet": (
        ["replay-day", "{data}", "--date", "0811", "--fleet", "fleet.toml", "--area", "Hubs"],
        ("--area hubs", "--fleet"),
    ),
    "replay-city-drones-square": (
        ["replay-day", "{data}", "--date", "0811", "--city-drones", "40", "--area", "square"],
        ("--city-drones", "--area square"),
    ),
    "replay-city-drones-fleet": (
        ["replay-day", "{data}", "--date", "0811", "--city-drones", "40", "--fleet", "fleet.toml"],
        ("--city-drones", "--fleet"),
    ),
    "segment-config-twice": (
        ["segment", "{data}", "--config", "a.toml", "--config", "b.toml"],
        ("--config given 2 times",),
    ),
    "replay-config-twice": (
        ["replay-day", "{data}", "--date", "0811", "--config=a.toml", "--config", "b.toml"],
        ("--config given 2 times",),
    ),
    "evaluate-config-twice": (
        ["evaluate", "{data}", "--config", "a.toml", "--config", "b.toml"],
        ("--config given 2 times",),
    ),
    "train-config-twice": (
        ["train", "{data}", "--config", "a.toml", "--config", "b.toml"],
        ("--config given 2 times",),
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_an_option_overridden_on_the_line_is_one_usage_error(
    files: Path, example_csv: Path, case: str
) -> None:
    args, needles = CASES[case]
    line = [a.replace("{data}", str(example_csv)) for a in args] + ["--out", "out"]
    json_doc = args[0] != "train"  # train has no --json
    line += ["--json"] * json_doc
    before = set(files.rglob("*"))
    res = run(line, files)
    assert res.returncode == 2, res.stderr
    (err,) = res.stderr.strip().splitlines()
    assert err.startswith("marops: error: ") and "Traceback" not in res.stderr
    for needle in needles:
        assert needle in err, (needle, err)
    if json_doc:
        doc = json.loads(res.stdout)
        assert doc["command"] == args[0] and doc["exit_code"] == 2
        assert f"marops: error: {doc['error']}" == err
    assert set(files.rglob("*")) == before, "something was written"


def test_a_value_from_the_environment_is_no_contradiction(files: Path, example_csv: Path) -> None:
    """``MAROPS_DRONES`` is the flag's default, as a config file's ``[sim] drones`` is:
    ``--fleet`` overrides it, as documented; the run goes on to read the fleet file."""
    line = ["replay-day", str(example_csv), "--date", "0811", "--fleet", "missing.toml"]
    res = run([*line, "--out", "out"], files, MAROPS_DRONES="4")
    assert res.returncode == 2
    assert "give at most one" not in res.stderr
    assert "missing.toml" in res.stderr


@pytest.mark.parametrize(
    ("fn", "kwargs", "needle"),
    [
        ("replay_day", {"drones": 4, "fleet": "fleet.toml"}, "drones or fleet"),
        ("replay_day", {"n_depots": 4, "depots": "d.json"}, "n_depots or depots"),
        ("replay_day", {"segment": "squares", "depots": "d.json"}, "segment or depots"),
        ("plan_window", {"drones": 4, "fleet": "fleet.toml"}, "drones or fleet"),
        ("replay_day", {"area": "hubs", "depots": "d.json"}, "area hubs or depots"),
        ("replay_day", {"city_drones": 40, "area": "square"}, "city_drones or area square"),
    ],
)
def test_the_api_refuses_the_same_pairs(
    files: Path, example_csv: Path, fn: str, kwargs: dict[str, object], needle: str
) -> None:
    from marops_cli import api
    from marops_cli.errors import InputError

    args: list[object] = [example_csv, "0811"]
    if fn == "plan_window":
        args = [example_csv, files / "d.json", "0811", 3]
    kwargs = {k: files / v if k in ("fleet", "depots") else v for k, v in kwargs.items()}
    with pytest.raises(InputError, match=f"give at most one of {needle}"):
        getattr(api, fn)(*args, **kwargs)

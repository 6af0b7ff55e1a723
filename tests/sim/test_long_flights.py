"""Under the paper's operating model (``busy = false``: every flight ends in its window)
a drone whose battery outlasts the window is said (docs/method.md, "Busy drones")."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app

SLOW = """[data]
area = "square"
window_min = 10
[ops]
stock = "any"
batteries_per_depot = "unlimited"
busy = {busy}
[energy]
speed_ms = {speed}
"""


@pytest.mark.parametrize(
    ("busy", "speed", "warned"),
    [("false", 0.5, True), ("true", 0.5, False), ("false", 10.0, False)],
    ids=["paper-slow", "busy-slow", "paper-fast"],
)
def test_a_battery_that_outlasts_the_window_is_said_under_busy_false(
    example_csv: Path, tmp_path: Path, busy: str, speed: float, warned: bool
) -> None:
    """0.5 m/s drones fly up to 20 min on a battery, past a 10-min window: under busy =
    false one line names the type and both durations. Nothing is said with busy = true
    (the drone is kept until it lands), nor for the default drone (18 min) in the
    default 30-min window."""
    cfg = tmp_path / "ops.toml"
    window = 10 if speed < 1 else 30
    cfg.write_text(SLOW.format(busy=busy, speed=speed).replace("10\n", f"{window}\n", 1))
    args = ["replay-day", str(example_csv), "--date", "0811", "--config", str(cfg)]
    args += ["--method", "stay", "--out", str(tmp_path / "out")]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.output.splitlines() if "flies up to" in ln]
    if warned:
        assert lines == [
            "warning: the fleet's drone type 'default' flies up to 20 min on a battery, "
            "longer than the 10-min window: under busy = false its drone is planned again "
            "in the next window while its flight may go on (busy = true keeps it until it "
            "lands)"
        ]
    else:
        assert lines == []

"""benchmarks/heldout.py's generalisation grid: its options, battery presets and table
arithmetic, on made-up rows (no replay)."""

from __future__ import annotations

import importlib.util
import tempfile
from pathlib import Path
from typing import Any

import pytest

from marops_cli.config import PlannerConfig, battery_preset, override
from marops_cli.policies.landing import operating_model

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("heldout", ROOT / "benchmarks" / "heldout.py")
assert _spec is not None and _spec.loader is not None
heldout = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(heldout)


@pytest.mark.parametrize(
    ("name", "spares", "chargers", "watts"),
    [("scarce", 1, 1, 31.0), ("default", 2, 1, 62.5), ("ample", 4, 2, 125.0)],
)
def test_battery_presets_set_the_ops_options(name: str, spares: int, chargers: int, watts: float):
    ops = override(PlannerConfig(), **battery_preset(name)).ops
    assert (ops.batteries_per_depot, ops.chargers_per_depot, ops.charge_power_w) == (
        spares,
        chargers,
        watts,
    )
    # The shipped actor flies under every preset: the operating model keeps its name.
    assert operating_model(ops) == operating_model(PlannerConfig().ops)


def test_without_the_new_options_the_plain_run_is_unchanged():
    a = heldout.parse_args([])
    assert not a.grid_run
    assert (a.depot_list, a.drone_list, a.alpha_list) == ([16, 25], [8, 16], [0.2, 0.5, 0.8])
    assert (a.battery_list, a.load_list, a.refs) == (["default"], [1.0], ["myopic"])


def test_grid_is_every_axis_and_the_rules():
    a = heldout.parse_args(["--grid"])
    assert a.grid_run and a.alpha_list == [0.5]
    assert (a.drone_list, a.depot_list) == ([4, 8, 16, 32], [16, 25, 36])
    assert (a.battery_list, a.load_list) == (["scarce", "default", "ample"], [1.0, 3.0])
    assert a.refs == ["ops-global", "backlog", "rebalance", "flow", "battery"]
    # An explicit axis replaces the grid's.
    assert heldout.parse_args(["--grid", "--drones", "8"]).drone_list == [8]


def test_smoke_with_the_new_axes_is_one_setting():
    a = heldout.parse_args(["--smoke", "--batteries", "scarce,ample", "--load", "3,1"])
    assert a.grid_run and (a.battery_list, a.load_list) == (["scarce"], [3.0])
    assert (a.shape_list, a.depot_list, a.drone_list) == (["hubs"], [16], [8])


@pytest.mark.parametrize(
    "argv",
    [["--batteries", "plenty"], ["--load", "0"], ["--load", "x"], ["--grid", "--alphas", "0.2"]],
)
def test_bad_grid_options_stop_with_usage(argv: list[str]):
    with pytest.raises(SystemExit) as exc:
        heldout.parse_args(argv)
    assert exc.value.code == 2


def _row(method: str, drones: int, day: str, j: float, energy: float, share: float,
         energy_kj: float, delivered: int, batteries: str = "default",
         choices: dict[str, int] | None = None) -> dict[str, Any]:  # fmt: skip
    return {
        "shape": "hubs", "n_depots": 16, "drones": drones, "batteries": batteries,
        "load": 1.0, "alpha": 0.5, "method": method, "day": day, "objective_j_mj": j,
        "mean_energy_kj": energy, "delivered_share": share,
        heldout.PER_PARCEL: energy / share, "energy_kj": energy_kj, "delivered": delivered,
        "choices": choices or {},
    }  # fmt: skip


ROWS = [
    # 8 drones, day 1: flow best (100 < 120); marops 10 MJ better, 10 kJ more, +0.1 share
    _row("marops", 8, "d1", 90, 110, 0.9, 880, 90, choices={"0": 6, "1": 2, "free": 2}),
    _row("flow", 8, "d1", 100, 100, 0.8, 800, 80),
    _row("backlog", 8, "d1", 120, 90, 0.7, 700, 70),
    # 8 drones, day 2: backlog best (200 < 230); marops 10 MJ better
    _row("marops", 8, "d2", 190, 100, 0.8, 800, 80, choices={"0": 4, "2": 6}),
    _row("flow", 8, "d2", 230, 100, 0.8, 800, 80),
    _row("backlog", 8, "d2", 200, 100, 0.8, 800, 80),
    # 16 drones, day 1: flow best (50); marops 50 MJ worse
    _row("marops", 16, "d1", 100, 100, 0.8, 800, 80, choices={"1": 3, "0": 1}),
    _row("flow", 16, "d1", 50, 100, 0.8, 800, 80),
    _row("backlog", 16, "d1", 60, 100, 0.8, 800, 80),
    # Another battery preset on the same day and drones: a setting of its own, its own best
    _row("marops", 8, "d1", 10, 100, 0.8, 800, 80, batteries="scarce", choices={"0": 1}),
    _row("flow", 8, "d1", 5, 100, 0.8, 800, 80, batteries="scarce"),
    _row("backlog", 8, "d1", 8, 100, 0.8, 800, 80, batteries="scarce"),
]


def test_grid_table_rows_and_pooled_row_by_hand(capsys: pytest.CaptureFixture[str]):
    table = heldout.grid_table(heldout.with_best(ROWS, ["flow", "backlog"]))
    keys = [(g["drones"], g["batteries"]) for g in table]
    assert keys == [(8, "scarce"), (8, "default"), (16, "default"), ("all", "all")]
    scarce, eight, sixteen, pooled = table

    assert eight["days"] == 2 and eight["j_better_days"] == 2
    # ΔJ −10 both days over the best rules' mean J (100 + 200) / 2 = 150
    assert eight["j_pct"] == pytest.approx((-100 * 10 / 150,) * 3)
    assert eight["j_mj"] == pytest.approx((-10, -10, -10))
    assert eight["energy_pct"][0] == pytest.approx(100 * 5 / 100)  # +10 and 0 kJ over 100
    assert eight["delivered_pts"][0] == pytest.approx(5.0)  # +0.1 and 0 share
    # per day: 110/0.9 − 100/0.8 and 0, over the best's mean 125
    assert eight["per_parcel_pct"][0] == pytest.approx(100 * (110 / 0.9 - 125) / 2 / 125)
    assert eight["kj_per_parcel"] == pytest.approx((1680 / 170, 1600 / 160))
    assert (eight["best_rule"], eight["best_rule_days"]) == ("backlog", 1)  # a tie: by name
    # marops's 20 decisions: stay 10, destination 1 twice, 2 six times, free twice
    assert (eight["top_action"], eight["top_share"]) == ("stay", 0.5)
    assert (eight["stay"], eight["move"], eight["free"]) == pytest.approx((0.5, 0.4, 0.1))

    assert sixteen["j_pct"] == pytest.approx((100.0,) * 3) and sixteen["j_better_days"] == 0
    assert (sixteen["top_action"], sixteen["top_share"], sixteen["stay"]) == ("1", 0.75, 0.25)
    assert (sixteen["best_rule"], sixteen["best_rule_days"]) == ("flow", 1)
    assert scarce["j_mj"] == pytest.approx((5, 5, 5))  # its own best (flow, 5), not day d1's

    # Pooled: ΔJ +5, −10, −10, +50 over the best's mean (5 + 100 + 200 + 50) / 4
    assert pooled["days"] == 4 and pooled["j_better_days"] == 2
    assert pooled["j_pct"][0] == pytest.approx(100 * (35 / 4) / (355 / 4))
    assert pooled["kj_per_parcel"] == pytest.approx((3280 / 330, 3200 / 320))
    assert pooled["decisions"] == 25 and pooled["stay"] == pytest.approx(12 / 25)

    heldout.print_grid(table, ["flow", "backlog"], markdown=True)
    out = capsys.readouterr().out
    assert "| 8 | 16 | default | ×1 | 2 | -6.7 [-6.7, -6.7] * |" in out
    assert "| all | all | all | all | 4 |" in out
    assert "settings: 3; Δ J interval below 0 in 1, above 0 in 2, containing 0 in 0" in out


def test_grid_tasks_are_its_settings_alone():
    a = heldout.parse_args(
        ["--shapes", "hubs", "--depots", "16", "--drones", "4,32", "--batteries",
         "scarce,ample", "--load", "1,3"]
    )  # fmt: skip
    files = {("hubs", 1.0): Path("hubs.csv"), ("hubs", 3.0): Path("hubs-x3.csv")}
    tasks = heldout.make_tasks(a, files)
    assert len(tasks) == 2 * 2 * 2 * 6  # loads × presets × drones × (marops and 5 rules)
    assert {(t[0], t[4], t[5], t[9], t[10]) for t in tasks} == {
        (f, u, 0.5, b, k)
        for k, f in ((1.0, "hubs.csv"), (3.0, "hubs-x3.csv"))
        for u in (4, 32)
        for b in ("scarce", "ample")
    }
    # The plain run still adds the α sweep's 16 areas and 8 drones.
    plain = heldout.parse_args(["--shapes", "hubs", "--depots", "16", "--drones", "16"])
    sweep = {(t[3], t[4], t[5]) for t in heldout.make_tasks(plain, files)}
    assert sweep == {(16, 16, 0.5), (16, 8, 0.2), (16, 8, 0.5), (16, 8, 0.8)}


def test_a_load_is_a_city_of_its_own(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    files = heldout.held_out_cities(["hubs"], 1, "heldout-", (1.0, 3.0))
    assert [p.name for p in files.values()] == ["hubs.csv", "hubs-x3.csv"]
    one, three = (len(p.read_text(encoding="utf-8").splitlines()) for p in files.values())
    assert 2.5 < three / one < 3.5

"""Every number a run accepts is finite and in the range docs/config.md gives; a setting
the data cannot meet blames the setting, not the data file."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from marops_cli.config import STAGES, PlannerConfig, load_config, value_range
from marops_cli.data.jsonfile import json_number
from marops_cli.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
NUMERIC = [
    (stage, name)
    for stage, model in STAGES.items()
    for name in model.model_fields
    if value_range(stage, name) is not None
]


def _docs_rows() -> dict[str, str]:
    text = (ROOT / "docs" / "config.md").read_text(encoding="utf-8")
    return {m.group(1): m.group(0) for m in re.finditer(r"^\| `([\w.]+)` \|.*$", text, re.M)}


@pytest.mark.parametrize(("stage", "name"), NUMERIC, ids=[f"{s}.{n}" for s, n in NUMERIC])
def test_the_docs_give_each_numbers_range(stage: str, name: str) -> None:
    row = _docs_rows().get(f"{stage}.{name}")
    assert row is not None, f"docs/config.md has no row for {stage}.{name}"
    assert f"| {value_range(stage, name)} |" in row, row
    default = getattr(getattr(PlannerConfig(), stage), name)  # also one left out of dumps
    if default is not None:  # the docs say what None means
        assert row.split(" | ")[1] == f"{default:g}", row


def test_the_defaults_and_examples_are_inside_the_ranges() -> None:
    PlannerConfig()  # validates
    for path in sorted((ROOT / "examples").glob("*.toml")):
        if path.name != "fleet.toml":
            load_config(path)


@pytest.mark.parametrize("value", [float("inf"), float("-inf"), float("nan"), 1e400])
def test_a_json_number_is_finite(value: float) -> None:
    with pytest.raises(InputError, match="expected a number"):
        json_number(value, "f.json", "hubs[0].drones")


@pytest.mark.parametrize(
    ("flag", "value", "expected"),
    [
        ("--drones", "100000", "1 ≤ drones ≤ 1000"),
        ("--alpha", "inf", "0.001 ≤ alpha ≤ 1"),
        # So small that the price of delay (1 − α)/α overflowed, and the day's J with it.
        ("--alpha", "1e-300", "0.001 ≤ alpha ≤ 1"),
    ],
)
def test_an_option_out_of_range_is_refused_up_front(
    example_csv: Path, tmp_path: Path, fails_cleanly, flag: str, value: str, expected: str
) -> None:
    args = ["replay-day", str(example_csv), "--date", "0811", "--method", "stay", flag, value]
    needles = (f"invalid option {flag}: ", expected, "docs/config.md")
    fails_cleanly([*args, "--out", str(tmp_path / "o")], tmp_path, *needles)


def test_a_hub_fleet_above_the_cap_names_the_key(tmp_path: Path) -> None:
    from marops_cli.config import DataConfig
    from marops_cli.segment.hubs import load_hubs

    hubs = tmp_path / "hubs.json"
    hubs.write_text('[{"center_lng": 121.4, "center_lat": 31.2, "drones": 5000}]')
    with pytest.raises(InputError, match=r"hubs\[0\]\.drones"):
        load_hubs(hubs, DataConfig())


@pytest.fixture
def few_points(tmp_path: Path) -> Path:
    from .bad_corpus import HEADER, _rows

    data = tmp_path / "few.csv"
    data.write_text("\n".join([HEADER, *_rows()]) + "\n", encoding="utf-8")
    return data


@pytest.mark.parametrize("command", ["segment", "replay-day"])
def test_more_depots_than_points_blames_the_config_key(
    few_points: Path, tmp_path: Path, fails_cleanly, command: str
) -> None:
    config = tmp_path / "many.toml"
    config.write_text("[segment]\nn_depots = 100\n")
    out = tmp_path / "out"
    args = [command, str(few_points), "--out", str(out / "d.json" if command == "segment" else out)]
    if command == "replay-day":
        args += ["--area", "square", "--date", "0811", "--method", "stay"]
    line = fails_cleanly([*args, "--config", str(config)], tmp_path, "key 'segment.n_depots'")
    assert line.startswith(f"marops: error: {config}, "), line
    assert "few.csv holds only 40 history requests" in line
    # Set by the option, the option is the culprit.
    line = fails_cleanly([*args, "--config", str(config), "--n-depots", "50"], tmp_path)
    assert "setting segment.n_depots: 50 depots asked for" in line
    assert str(config) not in line


def test_a_fleet_types_number_out_of_range_names_key_and_range(tmp_path: Path) -> None:
    from marops_cli.config import EnergyConfig
    from marops_cli.segment.depots import Depots
    from marops_cli.sim.fleet import load_fleet

    from .bad_corpus import DEPOT, FRAME

    depots = Depots.from_dict({"frame": FRAME, "depots": [DEPOT], "candidates": {"0": [0]}})
    fleet = tmp_path / "fleet.toml"
    fleet.write_text("[types.jet]\nspeed_ms = 400.0\n\n[counts]\njet = 1\n")
    with pytest.raises(InputError) as err:
        load_fleet(fleet, depots, 8, EnergyConfig())
    line = str(err.value)
    assert "key 'types.jet.speed_ms'" in line and "0.1 ≤ speed_ms ≤ 100" in line


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="a system without /dev/zero")
def test_an_endless_or_huge_small_input_is_refused_before_it_fills_memory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from marops_cli.segment.depots import Depots

    # A device that never ends: read up to the cap, then refused naming it.
    with pytest.raises(InputError, match="config file is larger than 64 MiB") as err:
        load_config("/dev/zero")
    assert err.value.file == "/dev/zero"
    # Any file above the cap (made small here).
    monkeypatch.setattr("marops_cli.data.jsonfile.MAX_SMALL_FILE", 16)
    big = tmp_path / "depots.json"
    big.write_text('{"frame": {}, "depots": [], "candidates": {}}')
    with pytest.raises(InputError, match="depots file is larger than"):
        Depots.load(big)
    small = tmp_path / "small.toml"
    small.write_text("[sim]\ndrones=3\n")  # 15 bytes: within the cap, read
    assert load_config(small).sim.drones == 3


def test_a_config_with_a_byte_order_mark_loads_as_without(tmp_path: Path) -> None:
    # Some editors start a UTF-8 file with a byte-order mark; TOML itself refuses one.
    plain = tmp_path / "plain.toml"
    plain.write_text("[plan]\nalpha = 0.3\n", encoding="utf-8")
    marked = tmp_path / "marked.toml"
    marked.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    assert load_config(marked) == load_config(plain)
    assert load_config(marked).plan.alpha == 0.3


@pytest.mark.parametrize("value", ["٠٩:٠٠", "+9:00", "9:0_0", "09:00:00", " 9:00", "9:0"])
def test_service_hours_take_ascii_digits_only(tmp_path: Path, value: str) -> None:
    """A time of day is HH:MM in ASCII digits: Python's int() took Arabic-Indic digits,
    a sign and an underscore, so such a config loaded as 09:00."""
    path = tmp_path / "c.toml"
    path.write_text(f'[data]\nservice_start = "{value}"\n', encoding="utf-8")
    with pytest.raises(InputError, match="service_start"):
        load_config(path)
    path.write_text('[data]\nservice_start = "9:30"\n', encoding="utf-8")
    assert load_config(path).data.service_start == "9:30"

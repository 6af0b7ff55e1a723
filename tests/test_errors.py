"""The one-line form of a bad-input error (docs/outputs.md, exit codes)."""

from __future__ import annotations

from marops_cli.errors import InputError


def test_a_table_names_row_and_column() -> None:
    line = str(InputError("not a number", file="day.csv", row=3, column="lat"))
    assert line == "day.csv, row 3, column 'lat': not a number"


def test_a_config_or_sidecar_names_the_key() -> None:
    line = str(InputError("expected > 0", file="fleet.toml", column="types.jet.speed_ms"))
    assert line == "fleet.toml, key 'types.jet.speed_ms': expected > 0"
    assert "key 'format'" in str(InputError("bad", file="a.JSON", column="format"))
    # a tensor of a weights file is not a key of a TOML or JSON file
    assert "column 'weight'" in str(InputError("bad", file="a.safetensors", column="weight"))

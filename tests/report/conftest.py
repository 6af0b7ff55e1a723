"""Small runs with ``--report`` (3 drones, four windows of the example's 2022-08-11), made
once per session and read by the report tests."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app

runner = CliRunner()


def invoke(*args: Any) -> Any:
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return res


@pytest.fixture(scope="session")
def small_config(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two service hours: four windows a day."""
    path = tmp_path_factory.mktemp("cfg") / "small.toml"
    path.write_text('[data]\nservice_start = "09:00"\nservice_end = "11:00"\n')
    return path


@pytest.fixture(scope="session")
def depots_json(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("seg") / "depots.json"
    invoke("segment", example_csv, "--dates", "0801..0810", "--out", path, "--quiet")
    return path


@pytest.fixture(scope="session")
def day_run(
    example_csv: Path,
    small_config: Path,
    depots_json: Path,
    tmp_path_factory: pytest.TempPathFactory,
) -> Path:
    """``replay-day --report`` of one small day."""
    out = tmp_path_factory.mktemp("day") / "0811"
    invoke(
        "replay-day", example_csv, "--date", "0811", "--depots", depots_json,
        "--drones", 3, "--config", small_config, "--report", "--out", out, "--quiet",
    )  # fmt: skip
    return out


@pytest.fixture(scope="session")
def json_day_run(
    example_csv: Path,
    small_config: Path,
    depots_json: Path,
    tmp_path_factory: pytest.TempPathFactory,
) -> Path:
    """``replay-day --format json --report`` of one small day (tests copy it before
    changing it)."""
    out = tmp_path_factory.mktemp("json") / "0811"
    invoke(
        "replay-day", example_csv, "--date", "0811", "--depots", depots_json, "--drones", 2,
        "--config", small_config, "--format", "json", "--report", "--out", out, "--quiet",
    )  # fmt: skip
    return out


@pytest.fixture(scope="session")
def days_run(
    example_csv: Path,
    small_config: Path,
    depots_json: Path,
    tmp_path_factory: pytest.TempPathFactory,
) -> Path:
    """``replay-day --report`` of two small days: three pages sharing one plotly.js."""
    out = tmp_path_factory.mktemp("days") / "days"
    invoke(
        "replay-day", example_csv, "--dates", "0811..0812", "--depots", depots_json,
        "--drones", 2, "--config", small_config, "--workers", 1, "--report", "--out", out,
        "--quiet",
    )  # fmt: skip
    return out


@pytest.fixture(scope="session")
def evaluation_run(
    example_csv: Path, small_config: Path, tmp_path_factory: pytest.TempPathFactory
) -> Path:
    """``evaluate --report`` of stay and greedy over two values of alpha, paired against
    stay, in one study square (tests copy it before changing it)."""
    out = tmp_path_factory.mktemp("ev") / "ev"
    invoke(
        "evaluate", "--area", "square", example_csv, "--dates", "0811", "--methods", "stay,greedy",
        "--against", "stay", "--alpha", "0.2,0.8", "--drones", 2, "--config", small_config,
        "--workers", 1, "--no-plot", "--report", "--out", out, "--quiet",
    )  # fmt: skip
    return out


def rewrite_parquet(path: Path, column: str, value: Callable[[Any], Any], **meta: Any) -> None:
    """Parquet ``column`` set to ``value(old value)`` in every row; the file's marops
    metadata kept, with the ``meta`` keys given replaced."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    i = table.schema.get_field_index(column)
    new = pa.array([value(v) for v in table.column(column).to_pylist()])
    table = table.set_column(i, pa.field(column, new.type), new)
    metadata = dict(pq.read_schema(path).metadata or {})
    if meta:
        metadata[b"marops"] = json.dumps({**json.loads(metadata[b"marops"]), **meta}).encode()
    pq.write_table(table.replace_schema_metadata(metadata), path)


def figure(html: str, div_id: str) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """(data, layout) of the plotly figure drawn into ``div_id``, read from the page."""
    start = re.search(r'Plotly\.newPlot\(\s*"' + re.escape(div_id) + r'",\s*', html)
    assert start is not None, f"no figure {div_id}"
    decoder = json.JSONDecoder()
    data, end = decoder.raw_decode(html, start.end())
    layout, _ = decoder.raw_decode(html, html.index("{", end))
    return data, layout


@pytest.fixture(scope="session")
def city_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``replay-day --hubs --report`` of a tiny synthetic city: three hubs placed on its
    first day, its second replayed with ``stay`` over one service hour, four depots a
    hub: the city's page, and a page per hub below it."""
    d = tmp_path_factory.mktemp("city")
    data, hubs, cfg = d / "city.csv", d / "hubs.json", d / "city.toml"
    cfg.write_text(
        '[data]\nservice_start = "09:00"\nservice_end = "10:00"\n[segment]\nn_depots = 4\n'
    )
    invoke("synth", "--out", data, "--days", 2, "--orders-per-day", 300, "--seed", 3)
    invoke("segment", data, "--hubs", 3, "--dates", "0801", "--out", hubs, "--quiet")
    out = d / "city"
    invoke(
        "replay-day", data, "--hubs", hubs, "--date", "0802", "--method", "stay",
        "--drones", 2, "--config", cfg, "--workers", 1, "--report", "--out", out, "--quiet",
    )  # fmt: skip
    return out

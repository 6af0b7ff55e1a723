"""The small files marops reads are pydantic models read by one helper
(marops_cli/data/filemodel.py; docs/decisions.md, "Files read"): a value of the wrong
kind, a key missing or a number out of range is one line naming the file and the key
path, and the command exits 2 having written nothing."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pydantic import Field

from marops_cli.data.filemodel import FileModel, Whole, validated
from marops_cli.data.frame import Frame
from marops_cli.errors import InputError
from marops_cli.policies.weights import network_sizes
from marops_cli.segment.depots import Depots, nearest_candidates


class _Item(FileModel):
    noun = "item"
    lng: float = Field(ge=-180, le=180)
    count: Whole = Field(0, ge=0)


class _Doc(FileModel):
    items: list[_Item]


@pytest.mark.parametrize(
    ("doc", "key", "says"),
    [
        (
            {"items": [{"lng": 1}, {"lng": 200}]},
            "items[1].lng",
            "expected -180 ≤ lng ≤ 180, got 200",
        ),
        ({"items": [{"lng": "1"}]}, "items[0].lng", "expected a number, got '1'"),
        ({"items": [{"lng": True}]}, "items[0].lng", "expected a number, got True"),
        ({"items": [{"lng": 1, "count": 2.5}]}, "items[0].count", "expected a whole number"),
        ({"items": [{"lng": 1, "count": -1}]}, "items[0].count", "expected count ≥ 0, got -1"),
        ({"items": [{}]}, "items[0].lng", "an item needs lng"),
        # A typo explains the key it misspells being missing: it is named first.
        ({"items": [{"lgn": 1}]}, "items[0].lgn", "unknown key 'lgn' in an item"),
        ({"items": [3]}, "items[0]", "expected an item {lng, …}, got 3"),
    ],
    ids=["range", "text", "switch", "fraction", "negative", "missing", "typo", "not-a-table"],
)
def test_one_line_names_the_key_path(tmp_path: Path, doc: object, key: str, says: str) -> None:
    path = tmp_path / "f.json"
    with pytest.raises(InputError) as err:
        validated(_Doc, doc, path)
    line = str(err.value)
    assert line.startswith(f"{path}, key '{key}': ") and says in line, line
    assert err.value.column == key and err.value.file == str(path) and err.value.exit_code == 2


def test_a_whole_number_written_as_a_float_is_one() -> None:
    assert validated(_Doc, {"items": [{"lng": 1, "count": 3.0}]}, "f.json").items[0].count == 3


@pytest.mark.parametrize(
    ("edit", "key", "says"),
    [
        (lambda s: s.update(obs_dim=True), "obs_dim", "a whole number from 1 to 100000, got True"),
        (lambda s: s.update(hidden_size=0), "hidden_size", "a whole number from 1 to 4096, got 0"),
        (lambda s: s.pop("n_logits"), "n_logits", "needs n_logits"),
    ],
    ids=["switch", "zero", "missing"],
)
def test_an_actor_sidecar_s_sizes_name_the_key(tmp_path: Path, edit, key: str, says: str) -> None:
    side = {"format": "marops-actor/1", "obs_dim": 8, "n_logits": 4, "hidden_size": 16, "x": 1}
    assert network_sizes(dict(side), tmp_path / "a.json") == (8, 4, 16)  # other keys kept
    edit(side)
    with pytest.raises(InputError) as err:
        network_sizes(side, tmp_path / "a.json")
    assert err.value.column == key and says in err.value.message


def _depots_file(path: Path) -> Path:
    xy = np.array([[0.0, 0.0], [2000.0, 0.0], [0.0, 3000.0]])
    dep = Depots(
        "kmeans", Frame(121.47, 31.23, 10.0), xy, np.array([5, 6, 7]), nearest_candidates(xy, 2)
    )
    path.write_text(json.dumps(dep.to_dict({})))
    return path


def test_bad_depots_hubs_and_fleet_files_stop_the_command(example_csv, tmp_path, fails_cleanly):
    """Out of range, missing, of the wrong kind: exit 2, one line, the file and key named."""
    good = _depots_file(tmp_path / "depots.json")
    doc = json.loads(good.read_text())
    doc["frame"]["center_lat"] = 123.0
    bad = tmp_path / "far.json"
    bad.write_text(json.dumps(doc))
    out = tmp_path / "out"
    day = [str(example_csv), "--date", "0811", "--out", str(out)]
    fails_cleanly(
        ["plan-window", *day, "--depots", str(bad), "--window", "1"],
        tmp_path,
        f"{bad}, key 'frame.center_lat': expected -90 ≤ center_lat ≤ 90, got 123.0",
    )
    hubs = tmp_path / "hubs.json"
    hubs.write_text(json.dumps({"hubs": [{"center_lng": 121.47}]}))
    fails_cleanly(
        ["replay-day", *day, "--method", "stay", "--hubs", str(hubs)],
        tmp_path,
        f"{hubs}, key 'hubs[0].center_lat': a hub needs center_lat",
    )
    fleet = tmp_path / "fleet.json"
    fleet.write_text(json.dumps({"drones": [{"depot": "north"}]}))
    fails_cleanly(
        ["replay-day", *day, "--method", "stay", "--depots", str(good), "--fleet", str(fleet)],
        tmp_path,
        f"{fleet}, key 'drones[0].depot': expected a whole number, got 'north'",
    )

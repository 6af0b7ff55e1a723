"""Counts and sizes bounded before any work (docs/config.md): a small file naming many
depots or hubs is one line naming its key, not hours of work or an exhausted memory."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

from marops_cli.app.segment import hub_count
from marops_cli.config import MAX_DEPOTS, DataConfig, SegmentConfig
from marops_cli.data.frame import Frame
from marops_cli.errors import InputError
from marops_cli.plans.ranges import flight_range, range_table
from marops_cli.segment.depots import Depots, nearest_candidates
from marops_cli.segment.hubs import MAX_HUBS, load_hubs

FRAME = {"center_lng": 121.47, "center_lat": 31.23, "size_km": 10.0}


def _depots_doc(n: int) -> dict:
    """A depots file of ``n`` depots on a line, each its own only candidate."""
    return {
        "frame": FRAME,
        "depots": [{"id": i, "x_m": float(i % 4000), "y_m": 0.0} for i in range(n)],
        "candidates": {str(i): [i] for i in range(n)},
    }


def test_a_depots_file_of_more_depots_than_a_study_area_has_is_refused_naming_the_key():
    doc = _depots_doc(MAX_DEPOTS + 1)
    with pytest.raises(InputError) as err:
        Depots.from_dict(doc, "d.json")
    assert err.value.column == "depots" and "4,097 depots" in str(err.value)
    # Counted before any depot is read: a fault further on is not what is said.
    del doc["depots"][4000]["x_m"]
    with pytest.raises(InputError, match="4,097 depots") as err:
        Depots.from_dict(doc, "d.json")
    assert err.value.column == "depots"
    assert len(Depots.from_dict(_depots_doc(MAX_DEPOTS), "d.json")) == MAX_DEPOTS


def test_the_depots_file_and_the_hubs_file_have_caps_of_their_own(tmp_path: Path):
    """Far below the 64 MiB of a config: parsing a file of that size takes gigabytes."""
    depots, hubs = tmp_path / "depots.json", tmp_path / "hubs.json"
    with depots.open("wb") as fh:
        fh.truncate((16 << 20) + 1)
    with hubs.open("wb") as fh:
        fh.truncate((1 << 20) + 1)
    with pytest.raises(InputError, match="depots file is larger than 16 MiB") as err:
        Depots.load(depots)
    assert err.value.file == str(depots)
    with pytest.raises(InputError, match="hubs file is larger than 1 MiB") as err:
        load_hubs(hubs, DataConfig())
    assert err.value.file == str(hubs)


def test_depots_and_candidates_whose_flight_range_table_is_too_large_are_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    """Every window sets up depots × candidates × depots flight ranges: 4,096 depots
    with 4,096 candidates each would be 68 GB. A config is refused naming its stage; a
    depots file with the run's candidates naming the file."""
    SegmentConfig(n_depots=4096, n_actions=16)
    with pytest.raises(ValidationError, match="at most 16 candidates for 4096 depots"):
        SegmentConfig(n_depots=4096, n_actions=17)
    SegmentConfig(n_depots=64, n_actions=4096)  # candidates are at most the depots
    path = tmp_path / "d.json"
    path.write_text(json.dumps(_depots_doc(6)))
    assert len(Depots.load(path, n_actions=4096)) == 6
    monkeypatch.setattr("marops_cli.config.MAX_RANGE_CELLS", 6 * 3 * 6)
    assert len(Depots.load(path, n_actions=3)) == 6
    with pytest.raises(InputError, match="6 depots with 4 action candidates") as err:
        Depots.load(path, n_actions=4)
    assert err.value.file == str(path) and err.value.column == "depots"


@pytest.mark.parametrize("n_actions", [1, 3, 5])
def test_the_range_table_holds_each_actions_flight_range(n_actions: int):
    """The table, found for many pairs at once, is :func:`flight_range` of each depot and
    candidate, ties (a grid's, depots at one place) to the lower id."""
    grid = np.stack(np.meshgrid(np.arange(7), np.arange(7)), -1).reshape(-1, 2) * 500.0
    xy = np.vstack([grid, grid[:3]])  # three depots sharing a place with others
    cand = nearest_candidates(xy, n_actions)
    depots = Depots("kmeans", Frame(121.47, 31.23, 10.0), xy, np.zeros(len(xy), int), cand)
    for coverage in (0.0, 0.1, 0.25, 1.0):
        table = range_table(depots, coverage)
        for s in range(len(xy)):
            for k in range(cand.shape[1]):
                want = flight_range(depots, s, int(cand[s, k]), coverage)
                assert np.array_equal(table[s, k], want), (coverage, s, k)


def test_a_hubs_file_of_more_hubs_than_a_city_is_tiled_into_is_refused_naming_the_key(
    tmp_path: Path,
):
    path = tmp_path / "hubs.json"
    hubs = [{"center_lng": 121.0 + i * 1e-3, "center_lat": 31.0} for i in range(MAX_HUBS + 1)]
    path.write_text(json.dumps({"hubs": hubs}))
    with pytest.raises(InputError, match="257 hubs") as err:
        load_hubs(path, DataConfig())
    assert err.value.column == "hubs" and err.value.file == str(path)
    path.write_text(json.dumps({"hubs": hubs[:MAX_HUBS]}))
    assert len(load_hubs(path, DataConfig())) == MAX_HUBS
    assert hub_count(str(MAX_HUBS)) == MAX_HUBS
    with pytest.raises(InputError, match="1 to 256"):
        hub_count("20000")


def test_a_depots_file_of_too_many_depots_stops_a_window_cleanly(
    example_csv: Path, tmp_path: Path, fails_cleanly
):
    depots = tmp_path / "d.json"
    depots.write_text(json.dumps(_depots_doc(MAX_DEPOTS + 1)))
    args = ["plan-window", str(example_csv), "--depots", str(depots), "--date", "0811"]
    fails_cleanly(
        [*args, "--window", "5", "--out", str(tmp_path / "w")], tmp_path, "'depots'", "4,097"
    )

"""The planner config of the use cases' options (marops_cli/app/options.py): one mapping
for the commands' flags and the Python API's keyword arguments."""

from __future__ import annotations

from pathlib import Path

import pytest

from marops_cli.app.options import planner_config
from marops_cli.app.replay import replay_config
from marops_cli.errors import InputError


def test_options_set_their_config_fields() -> None:
    cfg = planner_config(
        None, year=2021, alpha=0.2, drones=3, seed=5, n_depots=9, segment_seed=4, actions=2
    )
    assert (cfg.data.year, cfg.plan.alpha, cfg.sim.drones) == (2021, 0.2, 3)
    assert (cfg.sim.seed, cfg.segment.n_depots, cfg.segment.seed) == (5, 9, 4)
    assert cfg.segment.n_actions == 2


def test_unset_options_and_switches_left_off_keep_the_file_s_values(tmp_path: Path) -> None:
    toml = tmp_path / "planner.toml"
    toml.write_text("[data]\nstrict = true\n[plan]\nalpha = 0.3\n", encoding="utf-8")
    cfg = planner_config(toml, strict=False, alpha=None)
    assert cfg.data.strict is True
    assert cfg.plan.alpha == 0.3
    assert planner_config(None, strict=True).data.strict is True


def test_a_centre_is_read_from_text_and_a_bad_one_is_named() -> None:
    assert planner_config(None, center="121.47,31.23").data.center == (121.47, 31.23)
    with pytest.raises(InputError, match="--center"):
        planner_config(None, center="north")


def test_an_unknown_option_is_a_programming_error() -> None:
    with pytest.raises(TypeError, match="dronez"):
        planner_config(None, dronez=3)


def test_replay_segments_with_the_method_s_own_segmentation_unless_told() -> None:
    assert replay_config(None, method="squares").segment.method == "squares"
    assert replay_config(None, method="marops").segment.method == "kmeans"
    assert replay_config(None, method="squares", segment="kmeans").segment.method == "kmeans"

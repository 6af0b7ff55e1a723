"""Sweeps expand to the right combinations; days split 80/20; jobs in a fixed order."""

from __future__ import annotations

import datetime as dt

import pytest

from marops_cli.config import PlannerConfig
from marops_cli.errors import InputError
from marops_cli.evaluate import (
    Setting,
    expand_settings,
    parse_values,
    plan_jobs,
    split_days,
    swept_flags,
)
from marops_cli.evaluate.settings import check_settings


def test_no_flag_gives_the_config_setting() -> None:
    cfg = PlannerConfig()
    assert expand_settings(cfg) == [Setting(alpha=0.5, drones=8, coverage=0.25, depots_n=16)]
    assert swept_flags(expand_settings(cfg)) == []


def test_sweep_is_the_full_product_in_a_fixed_order() -> None:
    settings = expand_settings(PlannerConfig(), alpha=[0.2, 0.8], drones=[4, 8, 16])
    assert len(settings) == 6
    assert [(s.alpha, s.drones) for s in settings] == [
        (0.2, 4),
        (0.2, 8),
        (0.2, 16),
        (0.8, 4),
        (0.8, 8),
        (0.8, 16),
    ]
    assert {(s.coverage, s.depots_n) for s in settings} == {(0.25, 16)}
    assert swept_flags(settings) == ["alpha", "drones"]


def test_setting_config_applies_every_field_and_the_method_segmentation() -> None:
    s = Setting(alpha=0.2, drones=4, coverage=0.5, depots_n=9)
    cfg = s.config(PlannerConfig(), "ops-random", seed=3)
    assert (cfg.plan.alpha, cfg.sim.drones, cfg.plan.coverage) == (0.2, 4, 0.5)
    assert (cfg.segment.n_depots, cfg.segment.method, cfg.sim.seed) == (9, "kmeans", 3)


def test_parse_values() -> None:
    assert parse_values("0.2, 0.5,0.2", float, "--alpha") == [0.2, 0.5]
    assert parse_values(None, int, "--drones") is None
    with pytest.raises(InputError, match="--drones expects whole numbers"):
        parse_values("4,8.5", int, "--drones")


def test_invalid_setting_fails_before_running() -> None:
    with pytest.raises(InputError, match="alpha"):
        check_settings(PlannerConfig(), expand_settings(PlannerConfig(), alpha=[1.5]), ["greedy"])


@pytest.mark.parametrize(("n", "n_test"), [(50, 10), (12, 2), (90, 18), (3, 1), (2, 1)])
def test_split_takes_the_last_fifth_of_dates(n: int, n_test: int) -> None:
    days = [dt.date(2022, 8, 1) + dt.timedelta(days=i) for i in range(n)]
    test = split_days(days[::-1], "test")
    train = split_days(days, "train")
    assert test == days[-n_test:]
    assert train == days[:-n_test]


def test_evaluate_and_train_split_the_same_days() -> None:
    """``evaluate --split`` and ``marops train`` pick the same days (one 80/20 rule)."""
    from marops_cli.rl.data import split_days as train_split

    aug = [dt.date(2022, 8, d) for d in (12, 1, 5, 3, 9, 7, 2, 11, 4, 10, 8, 6, 13)]
    train, held = train_split(aug)
    assert held == [dt.date(2022, 8, 11), dt.date(2022, 8, 12), dt.date(2022, 8, 13)]
    assert train == sorted(aug)[:10]
    assert split_days(aug, "test") == held and split_days(aug, "train") == train
    for n in range(2, 40):
        days = [dt.date(2022, 8, 1) + dt.timedelta(days=i) for i in range(n)]
        assert train_split(days) == (split_days(days, "train"), split_days(days, "test"))


def test_split_needs_two_days() -> None:
    with pytest.raises(InputError, match="at least 2 days"):
        split_days([dt.date(2022, 8, 1)], "test")


def test_jobs_are_ordered_and_repeats_change_the_seed() -> None:
    days = [dt.date(2022, 8, 11), dt.date(2022, 8, 12)]
    jobs = plan_jobs(2, ["greedy", "ops-random"], days, repeats=2, seed=5)
    assert len(jobs) == 2 * 2 * 2 * 2
    assert [j.index for j in jobs] == list(range(len(jobs)))
    assert (jobs[0].setting, jobs[0].method, jobs[0].repeat, jobs[0].day) == (
        0,
        "greedy",
        0,
        days[0],
    )
    assert (jobs[3].repeat, jobs[3].seed, jobs[3].day) == (1, 6, days[1])
    assert jobs[4].method == "ops-random"
    assert jobs[8].setting == 1


def test_a_sweep_of_more_replays_than_the_bound_is_refused_before_it_is_listed() -> None:
    """Thousands of values of two flags once made a list of millions of settings (and of
    jobs) that filled memory: more than MAX_REPLAYS is one line naming the counts."""
    from marops_cli.evaluate.settings import MAX_REPLAYS

    alpha = [i / 1000 for i in range(1, 401)]
    with pytest.raises(InputError) as err:
        expand_settings(PlannerConfig(), alpha=alpha, drones=list(range(1, 301)))
    said = str(err.value)
    assert "120,000 replays (400 --alpha values × 300 --drones values)" in said
    assert f"{MAX_REPLAYS:,}" in said and "docs/config.md" in said
    assert (
        len(expand_settings(PlannerConfig(), alpha=alpha, drones=list(range(1, 251))))
        == MAX_REPLAYS
    )
    days = [dt.date(2022, 8, 11), dt.date(2022, 8, 12)]
    with pytest.raises(
        InputError, match=r"120,000 replays \(20,000 settings × 3 methods × 1 repeat × 2 days\)"
    ):
        plan_jobs(20_000, ["stay", "greedy", "myopic"], days, repeats=1, seed=0)
    hubs = [(0, days), (1, days[:1])]  # a city: each hub counts its own days
    with pytest.raises(InputError, match=r"× 3 days\)"):
        plan_jobs(20_000, ["stay", "greedy"], days, repeats=1, seed=0, hub_days=hubs)
    assert len(plan_jobs(20_000, ["stay"], days, repeats=1, seed=0, hub_days=hubs)) == 60_000


def test_a_one_day_file_names_its_day_for_dates() -> None:
    """An export of one day cannot be split; the line says the split is the default one
    and names the day to give as ``--dates``, where it only named ``--split``."""
    import pytest

    from marops_cli.errors import InputError

    with pytest.raises(
        InputError, match=r"by default test.*it has 1: name its day with --dates 0603"
    ):
        split_days([dt.date(2022, 6, 3)], "test")

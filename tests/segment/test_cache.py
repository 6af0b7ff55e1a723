"""The depots cache (docs/outputs.md, "Depots cache"): a hit is the same depots, bit for
bit, and anything the depots depend on makes another key."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pytest

from marops_cli.config import PlannerConfig, override
from marops_cli.data.frame import Frame
from marops_cli.segment.cache import cache_dir, cached_depots, depots_key
from marops_cli.segment.depots import Depots, nearest_candidates
from marops_cli.sim.scenario import load_scenario

DAYS = [dt.date(2022, 8, 1), dt.date(2022, 8, 2)]
FRAME = Frame(121.47, 31.23, 10.0)


def _depots() -> Depots:
    xy = np.array([[1.0 / 3.0, 2.0], [1000.123456789, -5.5]])
    return Depots("kmeans", FRAME, xy, np.array([4, 2]), nearest_candidates(xy, 2))


def test_hit_returns_the_same_depots_bit_for_bit(tmp_path, monkeypatch, points_table):
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    cfg = PlannerConfig()
    key = (points_table([121.47] * 3, [31.23] * 3, "abc"), DAYS, FRAME, cfg.data, cfg.segment)
    made = []

    def make() -> Depots:
        made.append(1)
        return _depots()

    a = cached_depots(*key, make)
    b = cached_depots(*key, make)
    assert len(made) == 1  # the second call is a hit
    assert a.xy.tobytes() == b.xy.tobytes()  # exact, not rounded like depots.json
    assert np.array_equal(a.candidates, b.candidates) and np.array_equal(a.n_history, b.n_history)
    assert b.method == "kmeans" and b.frame == FRAME
    assert len(list((tmp_path / "depots").glob("*.npz"))) == 1


def test_every_input_of_the_depots_changes_the_key():
    cfg = PlannerConfig()
    base = depots_key("abc", DAYS, FRAME, cfg.data, cfg.segment)
    other = [
        depots_key("abd", DAYS, FRAME, cfg.data, cfg.segment),
        depots_key("abc", DAYS[:1], FRAME, cfg.data, cfg.segment),
        depots_key("abc", DAYS, Frame(121.47, 31.23, 12.0), cfg.data, cfg.segment),
        depots_key("abc", DAYS, FRAME, cfg.data, override(cfg, segment__n_depots=9).segment),
        depots_key("abc", DAYS, FRAME, cfg.data, override(cfg, segment__seed=1).segment),
        depots_key("abc", DAYS, FRAME, override(cfg, data__window_min=20).data, cfg.segment),
    ]
    assert len({base, *other}) == 7


def test_off_and_unwritable_caches_only_cost_time(tmp_path, monkeypatch, points_table):
    cfg = PlannerConfig()
    key = (points_table([121.47] * 3, [31.23] * 3, "abc"), DAYS, FRAME, cfg.data, cfg.segment)
    monkeypatch.setenv("MAROPS_CACHE_DIR", "off")
    assert cache_dir() is None
    assert cached_depots(*key, _depots).xy.shape == (2, 2)
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(blocker))
    assert cached_depots(*key, _depots).xy.shape == (2, 2)  # no error, nothing cached


def test_a_run_from_the_cache_plans_what_the_run_that_filled_it_planned(
    example_csv: Path, tmp_path, monkeypatch
):
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    cfg = PlannerConfig()
    day = [dt.date(2022, 8, 11)]
    first = load_scenario(example_csv, cfg, replay_days=day)
    assert len(list((tmp_path / "depots").glob("*.npz"))) == 1
    second = load_scenario(example_csv, cfg, replay_days=day)
    assert first.depots.xy.tobytes() == second.depots.xy.tobytes()
    assert np.array_equal(first.depots.candidates, second.depots.candidates)
    assert np.array_equal(first.depots.arrivals, second.depots.arrivals)
    monkeypatch.setenv("MAROPS_CACHE_DIR", "off")
    fresh = load_scenario(example_csv, cfg, replay_days=day)
    assert fresh.depots.xy.tobytes() == first.depots.xy.tobytes()
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    nine = load_scenario(example_csv, override(cfg, segment__n_depots=9), replay_days=day)
    assert len(nine.depots) == 9  # another n_depots is another key, not the 16 above
    assert len(list((tmp_path / "depots").glob("*.npz"))) == 2


def _stored(tmp_path, monkeypatch, points_table):
    """Depots cached under ``tmp_path``: the key, the depots, the entry's path and its
    arrays as stored."""
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    cfg = PlannerConfig()
    key = (points_table([121.47] * 3, [31.23] * 3, "abc"), DAYS, FRAME, cfg.data, cfg.segment)
    good = _depots()
    cached_depots(*key, lambda: good)
    (path,) = (tmp_path / "depots").glob("*.npz")
    return key, good, path, dict(np.load(path, allow_pickle=False))


def test_a_damaged_or_edited_cache_is_a_miss(tmp_path, monkeypatch, points_table):
    """A cache file cut short, holding what no segmentation makes (NaN or far-away
    positions, candidates that are no depot, counts that do not match, text), or edited
    since it was stored (depots moved 500 m), is segmented again and cached anew, never
    a failed run or moved depots."""
    key, good, path, fine = _stored(tmp_path, monkeypatch, points_table)
    edits = {
        "nan": dict(fine, xy=np.array([[np.nan, 0.0], [1.0, 2.0]])),
        "far": dict(fine, xy=fine["xy"] + 1e10),
        "ids": dict(fine, candidates=fine["candidates"] + 100),
        "counts": dict(fine, n_history=np.array([4])),
        "text": dict(fine, xy=np.array([["a", "b"], ["c", "d"]])),
        # Plausible, but not what was stored: the digest stored with it tells.
        "moved": dict(fine, xy=fine["xy"] + 500.0),
        "no digest": {k: v for k, v in fine.items() if k != "digest"},
    }
    for name, arrays in [("cut", None), *edits.items()]:
        if arrays is None:
            path.write_bytes(path.read_bytes()[:40])
        else:
            with path.open("wb") as fh:
                np.savez(fh, **arrays)
        made: list[str] = []

        def make(made: list[str] = made, name: str = name) -> Depots:
            made.append(name)
            return good

        got = cached_depots(*key, make)
        assert made == [name] and got.xy.tobytes() == good.xy.tobytes(), name
        assert cached_depots(*key, make).xy.tobytes() == good.xy.tobytes()
        assert made == [name], name  # cached anew: the next run is a hit


def test_a_compressed_entry_that_unpacks_past_the_bound_is_a_miss_unread(
    tmp_path, monkeypatch, points_table
):
    """An entry of compressed arrays (``np.savez_compressed``) whose positions unpack to
    64 MiB of zeros from 64 kB (2 MiB made the run take 2.5 GB and 11 s): a miss,
    segmented again and cached anew, before any array is unpacked."""
    import tracemalloc

    from marops_cli.segment.cache import MAX_ENTRY

    key, good, path, fine = _stored(tmp_path, monkeypatch, points_table)
    with path.open("wb") as fh:
        np.savez_compressed(fh, **dict(fine, xy=np.zeros((MAX_ENTRY // 4, 2))))
    assert path.stat().st_size < MAX_ENTRY // 100
    made: list[int] = []
    tracemalloc.start()
    try:
        got = cached_depots(*key, lambda: made.append(1) or good)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert made == [1] and got.xy.tobytes() == good.xy.tobytes()
    assert peak < MAX_ENTRY // 2, peak
    assert cached_depots(*key, lambda: 1 / 0).xy.tobytes() == good.xy.tobytes()  # anew


def test_a_cache_folder_under_an_unknown_home_is_no_cache(monkeypatch, points_table):
    """``~nosuchuser/…`` (or no home at all) cannot be expanded: the run segments
    without the cache rather than stopping on a traceback."""
    cfg = PlannerConfig()
    key = (points_table([121.47] * 3, [31.23] * 3, "abc"), DAYS, FRAME, cfg.data, cfg.segment)
    monkeypatch.setenv("MAROPS_CACHE_DIR", "~no-such-user-of-marops/cache")
    assert cache_dir() is None
    assert cached_depots(*key, _depots).xy.shape == (2, 2)


def _key_path(root: Path, table, cfg: PlannerConfig) -> Path:
    import hashlib

    rows = hashlib.sha256(np.ascontiguousarray(table.row).tobytes()).hexdigest()
    key = depots_key(f"{table.source.sha256}:{rows}", DAYS, FRAME, cfg.data, cfg.segment)
    return root / "depots" / f"{key}.npz"


def test_a_cache_file_of_other_depots_under_this_key_is_a_miss(tmp_path, monkeypatch, points_table):
    """A file copied or renamed into the cache (well-formed, but made for other inputs)
    is never taken for these depots: the run segments again and caches anew."""
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    cfg = override(PlannerConfig(), segment__n_depots=2, segment__n_actions=2)
    table = points_table([121.47] * 3, [31.23] * 3, "abc")
    path = _key_path(tmp_path, table, cfg)
    path.parent.mkdir(parents=True)
    other = np.array([[5.0, 5.0], [-7.0, 9.0]])
    np.savez(
        path,
        method=np.array("kmeans"),
        xy=other,
        n_history=np.array([9, 1]),
        candidates=nearest_candidates(other, 2),
    )
    got = cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, _depots)
    assert got.xy.tobytes() == _depots().xy.tobytes()
    again = cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, lambda: 1 / 0)
    assert again.xy.tobytes() == _depots().xy.tobytes()  # the file now holds these


def test_a_cache_that_cannot_be_stored_leaves_no_temporary_behind(
    tmp_path, monkeypatch, points_table
):
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    cfg = PlannerConfig()
    table = points_table([121.47] * 3, [31.23] * 3, "abc")
    path = _key_path(tmp_path, table, cfg)
    path.mkdir(parents=True)  # a folder where the cache file goes
    with pytest.warns(UserWarning, match="is not a regular file"):
        got = cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, _depots)
    assert got.xy.shape == (2, 2)
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]


def test_ctrl_c_as_an_entry_is_stored_leaves_no_temporary_behind(
    tmp_path, monkeypatch, points_table
):
    """Ctrl-C (or SIGTERM) while an entry was written left its temporary
    (``.KEY.npz.XXXXXXXX.tmp``) in the cache folder for good: one more for each run so
    stopped."""
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    cfg = PlannerConfig()
    table = points_table([121.47] * 3, [31.23] * 3, "abc")
    path = _key_path(tmp_path, table, cfg)

    def savez(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", savez)
    with pytest.raises(KeyboardInterrupt):
        cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, _depots)
    assert list(path.parent.iterdir()) == []


def test_a_link_planted_at_a_temporary_name_is_never_written_through(
    tmp_path, monkeypatch, points_table
):
    """The cache's temporary is a file made new: a link planted in a shared cache under
    any name a run could pick for it (the key is computable from the data) leaves its
    target as it was."""
    import os

    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path / "cache"))
    cfg = PlannerConfig()
    table = points_table([121.47] * 3, [31.23] * 3, "abc")
    path = _key_path(tmp_path / "cache", table, cfg)
    path.parent.mkdir(parents=True)
    victim = tmp_path / "victim.txt"
    victim.write_text("PRECIOUS")
    (path.parent / f".{path.name}.{os.getpid()}.tmp").symlink_to(victim)
    cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, _depots)
    assert victim.read_text() == "PRECIOUS"
    assert path.is_file() and not path.is_symlink()
    assert path.stat().st_mode & 0o777 == 0o644  # others sharing the cache read it
    again = cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, lambda: 1 / 0)
    assert again.xy.tobytes() == _depots().xy.tobytes()  # the depots were cached


def test_a_relative_xdg_cache_home_is_ignored(tmp_path, monkeypatch):
    """XDG_CACHE_HOME=cache names no folder (the XDG rule for a relative path): the cache
    is ~/.cache/marops, not a folder of the directory the run started in."""
    monkeypatch.delenv("MAROPS_CACHE_DIR", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("XDG_CACHE_HOME", "cache")
    assert cache_dir() == tmp_path / "home" / ".cache" / "marops"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "marops"


def _tampered(path: Path) -> None:
    """Rewrite the cache entry ``path`` as someone sharing the cache could: the same key
    and shape, every depot moved to one corner of the study square (well-formed, and
    plausible: inside the square)."""
    arrays = dict(np.load(path, allow_pickle=False))
    corner = np.full_like(arrays["xy"], FRAME.half_m * 0.99)
    corner[:, 0] -= np.arange(corner.shape[0])
    arrays["xy"] = corner
    path.unlink()
    with path.open("wb") as fh:
        np.savez(fh, **arrays)


def _as_another_user(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``path`` owned by another user: given away where this process may (root), else
    this process takes another uid for the cache's checks."""
    import os

    if os.geteuid() == 0:
        os.chown(path, 65534, 65534)
    else:
        mine = os.getuid()
        monkeypatch.setattr(os, "getuid", lambda: mine + 1)


def test_another_users_entry_is_neither_used_nor_replaced(tmp_path, monkeypatch, points_table):
    """A shared cache folder (``MAROPS_CACHE_DIR`` on a folder others write): an entry
    another user wrote or edited (depots moved to a corner) would move this run's
    depots. It is not used, nor replaced: the run segments again and says so."""
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    cfg = PlannerConfig()
    table = points_table([121.47] * 3, [31.23] * 3, "abc")
    path = _key_path(tmp_path, table, cfg)
    cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, _depots)
    _tampered(path)
    _as_another_user(path, monkeypatch)
    theirs = path.read_bytes()
    made: list[int] = []

    def make() -> Depots:
        made.append(1)
        return _depots()

    with pytest.warns(UserWarning, match="belongs to another user"):
        got = cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, make)
    assert made == [1] and got.xy.tobytes() == _depots().xy.tobytes()
    assert path.read_bytes() == theirs  # their file, left as it was


def test_an_entry_others_may_write_is_not_used_and_is_cached_anew(
    tmp_path, monkeypatch, points_table
):
    """This user's entry that others may write (mode 0666) may hold anything: not used;
    being this user's, it is replaced by the depots segmented anew (0644), a hit next."""
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    cfg = PlannerConfig()
    table = points_table([121.47] * 3, [31.23] * 3, "abc")
    path = _key_path(tmp_path, table, cfg)
    cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, _depots)
    _tampered(path)
    path.chmod(0o666)
    with pytest.warns(UserWarning, match="may be written by other users"):
        got = cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, _depots)
    assert got.xy.tobytes() == _depots().xy.tobytes()
    assert path.stat().st_mode & 0o777 == 0o644
    again = cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, lambda: 1 / 0)
    assert again.xy.tobytes() == _depots().xy.tobytes()


def test_a_link_at_an_entry_is_not_followed(tmp_path, monkeypatch, points_table):
    """A link under a key's name (to a file of this user's, of the right form) is no
    entry a run wrote: not used, not replaced."""
    monkeypatch.setenv("MAROPS_CACHE_DIR", str(tmp_path))
    cfg = PlannerConfig()
    table = points_table([121.47] * 3, [31.23] * 3, "abc")
    path = _key_path(tmp_path, table, cfg)
    cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, _depots)
    _tampered(path)
    target = tmp_path / "elsewhere.npz"
    path.rename(target)
    path.symlink_to(target)
    with pytest.warns(UserWarning, match="is a symbolic link"):
        got = cached_depots(table, DAYS, FRAME, cfg.data, cfg.segment, _depots)
    assert got.xy.tobytes() == _depots().xy.tobytes()
    assert path.is_symlink() and path.resolve() == target

"""Depots, candidates, service areas: hand-checkable layouts."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from numpy.testing import assert_allclose
from sklearn.cluster import KMeans

from marops_cli.config import SegmentConfig
from marops_cli.data.frame import Frame
from marops_cli.errors import InputError
from marops_cli.segment import (
    Depots,
    area_polygons,
    areas_geojson,
    kmeans_depots,
    nearest_candidates,
    squares_depots,
)

from .conftest import moved_example

FRAME = Frame(121.47, 31.23, 10.0)


def _signed_area(poly: list[tuple[float, float]] | np.ndarray) -> float:
    """Shoelace area: positive for a counter-clockwise ring."""
    arr = np.array(poly)
    x, y = arr[:, 0], arr[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _poly_area(poly: list[tuple[float, float]]) -> float:
    return abs(_signed_area(poly))


def test_candidates_itself_first_then_nearest() -> None:
    # Four depots on a line at 0, 1, 3, 7 km: depot 1's nearest are 0 (1 km), then 2 (2 km).
    xy = np.array([[0.0, 0.0], [1000.0, 0.0], [3000.0, 0.0], [7000.0, 0.0]])
    cand = nearest_candidates(xy, 3)
    # By nearness alone depot 2's moves are 1 and 0, and no depot's move reaches 3: a
    # drone could never fly there. Depot 2, the nearest to 3, gives its farthest move
    # (0, 3 km; it stays in 0, 1, 2's group, which 1 still joins) to 3.
    assert cand.tolist() == [[0, 1, 2], [1, 0, 2], [2, 1, 3], [3, 2, 1]]


def _reach(cand: np.ndarray, start: int) -> set[int]:
    """The depots a drone at ``start`` can reach by moves (``cand[i, 1:]``)."""
    seen, todo = {start}, [start]
    while todo:
        for j in cand[todo.pop(), 1:].tolist():
            if j not in seen:
                seen.add(j)
                todo.append(j)
    return seen


def test_candidates_reach_every_depot_of_two_villages() -> None:
    # Two villages 8 km apart, four depots each on a 100 m square: each depot's three
    # nearest are its village's, so no move would ever leave a village. The nearest pair
    # across (depot 1 at (100, 0) and depot 4 at (8000, 0)) each give their farthest move
    # (the square's diagonal: 3 and 7) to the other; every other row is nearness alone.
    square = np.array([[0.0, 0.0], [100.0, 0.0], [0.0, 100.0], [100.0, 100.0]])
    xy = np.vstack([square, square + [7900.0, 0.0]])
    cand = nearest_candidates(xy, 4)
    assert cand.tolist() == [
        [0, 1, 2, 3], [1, 0, 3, 4], [2, 0, 3, 1], [3, 1, 2, 0],
        [4, 5, 6, 1], [5, 4, 7, 6], [6, 4, 7, 5], [7, 5, 6, 4],
    ]  # fmt: skip
    for i in range(8):
        assert _reach(cand, i) == set(range(8)), i
    # Depots already all reachable keep their nearest moves; one move each is kept too.
    line = np.array([[0.0, 0.0], [1000.0, 0.0], [2000.0, 0.0], [3000.0, 0.0]])
    assert nearest_candidates(line, 3).tolist() == [[0, 1, 2], [1, 0, 2], [2, 1, 3], [3, 2, 1]]
    assert nearest_candidates(xy, 2)[:, 1].tolist() == [1, 0, 0, 1, 5, 4, 4, 5]


def test_candidates_ties_go_to_lower_id_and_cap_at_n() -> None:
    xy = np.array([[0.0, 0.0], [1000.0, 0.0], [-1000.0, 0.0]])
    cand = nearest_candidates(xy, 10)
    assert cand.shape == (3, 3)
    assert cand[0].tolist() == [0, 1, 2]  # 1 and 2 both 1 km away: lower id first


def test_squares_gives_regular_grid() -> None:
    cfg = SegmentConfig(method="squares", n_depots=16)
    dep = squares_depots(np.zeros(1), np.zeros(1), FRAME, cfg)
    xs = np.unique(np.round(dep.xy[:, 0], 6))
    ys = np.unique(np.round(dep.xy[:, 1], 6))
    assert_allclose(xs, [-3750.0, -1250.0, 1250.0, 3750.0], atol=1e-9)
    assert_allclose(ys, xs, atol=1e-9)
    # Every cell is a 2.5 km square: the Voronoi cells of a regular grid.
    for poly in area_polygons(dep):
        assert_allclose(_poly_area(poly), 2500.0**2, rtol=1e-9)


def test_squares_needs_square_number() -> None:
    with pytest.raises(ValueError, match="square number"):
        SegmentConfig(method="squares", n_depots=10)


def test_kmeans_inertia_matches_sklearn() -> None:
    rng = np.random.default_rng(3)
    centres = rng.uniform(-4000, 4000, size=(8, 2))
    pts = np.concatenate([c + rng.normal(0, 400, size=(300, 2)) for c in centres])
    cfg = SegmentConfig(n_depots=8, seed=5)
    dep = kmeans_depots(pts[:, 0], pts[:, 1], FRAME, cfg)
    ref = KMeans(n_clusters=8, n_init=cfg.n_init, random_state=5).fit(pts)
    ours = float(((pts - dep.xy[dep.assign(pts[:, 0], pts[:, 1])]) ** 2).sum())
    assert abs(ours - ref.inertia_) / ref.inertia_ < 0.01
    assert dep.n_history.sum() == pts.shape[0]
    assert (dep.candidates[:, 0] == np.arange(8)).all()


def test_kmeans_depots_do_not_depend_on_the_row_order() -> None:
    """The same history in another row order (an export sorted otherwise, a database
    dump's arbitrary order) gives the very same depots: k-means++ seeds by row index, so
    uniform points, where its local optima are many, gave other depots when shuffled."""
    rng = np.random.default_rng(7)
    pts = np.round(rng.uniform(-4500, 4500, size=(2000, 2)), 1)
    cfg = SegmentConfig(n_depots=16, seed=0)
    first = kmeans_depots(pts[:, 0], pts[:, 1], FRAME, cfg)
    for order in (pts[::-1], pts[rng.permutation(len(pts))], pts[np.argsort(pts[:, 1])]):
        dep = kmeans_depots(order[:, 0], order[:, 1], FRAME, cfg)
        assert dep.xy.tobytes() == first.xy.tobytes()
        assert dep.candidates.tolist() == first.candidates.tolist()
        assert dep.n_history.tolist() == first.n_history.tolist()


def test_kmeans_needs_enough_points() -> None:
    with pytest.raises(InputError, match="16 depots asked for, but .* holds only 3 history"):
        kmeans_depots(np.zeros(3), np.zeros(3), FRAME, SegmentConfig())


def test_areas_partition_the_square() -> None:
    rng = np.random.default_rng(0)
    xy = rng.uniform(-5000, 5000, size=(9, 2))
    dep = Depots("kmeans", FRAME, xy, np.zeros(9, dtype=int), nearest_candidates(xy, 4))
    polys = area_polygons(dep)
    assert_allclose(sum(_poly_area(p) for p in polys), 10_000.0**2, rtol=1e-9)
    # A point inside depot i's polygon is assigned to depot i: test each polygon's centroid.
    for i, poly in enumerate(polys):
        c = np.array(poly).mean(axis=0)
        assert dep.assign(c[:1], c[1:])[0] == i


def test_json_round_trip_and_geojson(tmp_path) -> None:
    xy = np.array([[0.0, 0.0], [2000.0, 0.0], [0.0, 3000.0]])
    dep = Depots("kmeans", FRAME, xy, np.array([5, 6, 7]), nearest_candidates(xy, 2))
    doc = dep.to_dict({"version": "x"})
    assert doc["candidates"] == {"0": [0, 1], "1": [1, 0], "2": [2, 0]}
    path = tmp_path / "depots.json"
    path.write_text(json.dumps(doc))
    back = Depots.load(path)
    assert_allclose(back.xy, xy, atol=1e-3)
    assert back.candidates.tolist() == dep.candidates.tolist()
    assert back.frame == FRAME
    gj = areas_geojson(dep, {})
    kinds = [f["properties"]["kind"] for f in gj["features"]]
    assert kinds.count("depot") == 3 and kinds.count("service_area") == 3


def test_bad_depots_file(tmp_path) -> None:
    p = tmp_path / "d.json"
    p.write_text("{not json")
    with pytest.raises(InputError, match="d.json"):
        Depots.load(p)
    p.write_text(json.dumps({"frame": {}, "depots": []}))
    with pytest.raises(InputError, match="not a marops depots file"):
        Depots.load(p)


@pytest.mark.parametrize(
    ("edit", "key", "got"),
    [
        (lambda d: d["candidates"]["1"].__setitem__(1, 0.9), "candidates.1", "0.9"),
        (lambda d: d["candidates"]["1"].__setitem__(1, "0"), "candidates.1", "'0'"),
        (lambda d: d["candidates"]["1"].__setitem__(1, False), "candidates.1", "False"),
        (lambda d: d["frame"].__setitem__("size_km", "10"), "frame.size_km", "'10'"),
        (lambda d: d["depots"][2].__setitem__("n_history", 2.5), "depots[2].n_history", "2.5"),
    ],
    ids=["fraction-id", "text-id", "switch-id", "text-size", "fraction-count"],
)
def test_a_depots_file_s_ids_and_numbers_are_never_converted(tmp_path, edit, key, got) -> None:
    """A candidate 0.9, "0" or false became depot 0 (int() truncates), a size "10" became
    10 km: each is one line naming the key, as docs/config.md says of every number."""
    xy = np.array([[0.0, 0.0], [2000.0, 0.0], [0.0, 3000.0]])
    doc = Depots("kmeans", FRAME, xy, np.array([5, 6, 7]), nearest_candidates(xy, 2)).to_dict({})
    edit(doc)
    path = tmp_path / "depots.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=rf"key '{re.escape(key)}': expected a .*, got {got}"):
        Depots.load(path)


def _edited_depots_error(tmp_path, edit, key: str, says: str) -> str:
    """The error line of a depots file marops wrote, once ``edit`` has changed it: it
    names the file and ``key`` and says ``says``."""
    xy = np.array([[0.0, 0.0], [2000.0, 0.0], [0.0, 3000.0]])
    doc = Depots("kmeans", FRAME, xy, np.array([5, 6, 7]), nearest_candidates(xy, 2)).to_dict({})
    edit(doc)
    path = tmp_path / "depots.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError) as err:
        Depots.load(path)
    line = str(err.value)
    assert line.startswith(f"{path}, key '{key}': "), line
    assert says in line, line
    return line


@pytest.mark.parametrize(
    ("edit", "key", "says"),
    [
        (lambda d: d.__setitem__("candidates", [[0, 1], [1, 0], [2, 0]]), "candidates", "a list"),
        (lambda d: d.pop("candidates"), "candidates", "got nothing"),
        (lambda d: d["candidates"].pop("1"), "candidates.1", "got nothing for depot 1"),
        (lambda d: d["candidates"].__setitem__("1", 1), "candidates.1", "got 1 for depot 1"),
        (lambda d: d["candidates"].__setitem__("2", []), "candidates.2", "an empty list"),
        (lambda d: d["candidates"].__setitem__("2", [2]), "candidates.2", "got 1 candidates"),
        (lambda d: d["candidates"].__setitem__("3", [3, 0]), "candidates.3", "'3' (ids 0..2)"),
        (lambda d: d["candidates"].__setitem__("2", [2, 1e300]), "candidates.2", "unknown"),
        (lambda d: d["candidates"].__setitem__("2", [0, 2]), "candidates.2", "itself first"),
    ],
    ids=["list", "absent", "missing-depot", "number", "empty", "ragged", "extra-id", "huge-id"]
    + ["not-itself-first"],
)
def test_candidates_of_the_wrong_shape_name_the_key_and_the_shape(
    tmp_path, edit, key, says
) -> None:
    """A ``candidates`` that is not one list per depot, itself first, all as long: one
    line naming the key and what it should hold (an empty list was a traceback, a list
    of lists said only 'list indices must be integers')."""
    line = _edited_depots_error(tmp_path, edit, key, says)
    if "unknown" not in says and "itself" not in says:
        assert '{"0": [0, 4, 1], "1": [1, 0, 2], …}' in line


@pytest.mark.parametrize(
    ("edit", "key", "says"),
    [
        (lambda d: d["depots"][1].pop("x_m"), "depots[1].x_m", "a depot needs x_m"),
        (lambda d: d["depots"][1].pop("id"), "depots[1].id", "a depot needs id"),
        (lambda d: d["depots"][1].__setitem__("id", None), "depots[1].id", "got null"),
        (lambda d: d["depots"][1].__setitem__("id", [1]), "depots[1].id", "number, got a list"),
        (lambda d: d["depots"][2].__setitem__("id", 1), "depots[].id", "as an earlier depot does"),
        (lambda d: d["depots"][2].__setitem__("id", 99), "depots[].id", "id 99, outside 0..2"),
        (lambda d: d["depots"].__setitem__(1, [0.0, 0.0]), "depots[1]", "got a list"),
        (lambda d: d.__setitem__("depots", {"0": {}}), "depots", "got an object"),
        (lambda d: d.pop("depots"), "depots", "got nothing"),
        (lambda d: d.__setitem__("frame", None), "frame", "got null"),
        (lambda d: d.pop("frame"), "frame", "got nothing"),
        (lambda d: d["frame"].pop("size_km"), "frame.size_km", "the frame needs size_km"),
        (lambda d: d["frame"].__setitem__("zoom", 3), "frame.zoom", "unknown key 'zoom'"),
        (lambda d: d["depots"][2].__setitem__("n_history", -5), "depots[2].n_history", "-5"),
        (lambda d: d["depots"][2].__setitem__("n_history", 10**30), "depots[2].n_history", "2^53"),
        (lambda d: d.__setitem__("method", ["kmeans"]), "method", "got a list"),
        (lambda d: d.__setitem__("method", "voronoi"), "method", "kmeans or squares, got 'vor"),
        (lambda d: d.__setitem__("meta", 5), "meta", "provenance object, got 5"),
    ],
    ids=["no-x", "no-id", "null-id", "list-id", "id-twice", "id-beyond", "depot-list"]
    + ["depots-object", "no-depots"]
    + ["null-frame", "no-frame", "frame-no-size", "frame-extra", "negative-count", "huge-count"]
    + ["method-list"]
    + ["method-unknown", "meta-number"],
)
def test_a_depots_file_of_another_shape_names_the_key(tmp_path, edit, key, says) -> None:
    """A depot without x_m, an id of null, a frame without its size, a count too large
    for a 64-bit integer: one line naming the key (each said only 'not a marops depots
    file' with Python's words for the failure: 'x_m', 'Frame.__init__() missing 1
    required positional argument', 'Python int too large to convert to C long'; a
    negative count and a method that is a list were taken)."""
    line = _edited_depots_error(tmp_path, edit, key, says)
    assert "__init__" not in line and "C long" not in line, line


# Areas (m²) of the example's 16 service areas (README's `segment --dates 0801..0810`)
# as the half-plane clipping that shapely's Voronoi cells replaced drew them.
EXAMPLE_AREAS_M2 = [
    9133849, 6979254, 11837988, 9460616, 3981961, 3886630, 7337758, 6959736,
    4036096, 3234725, 3230467, 3384234, 8702184, 6342976, 6724122, 4767403,
]  # fmt: skip


def test_example_cells_keep_their_areas(example_csv) -> None:
    from marops_cli.app.segment import segment
    from marops_cli.config import PlannerConfig

    dep = segment(example_csv, PlannerConfig(), days="0801..0810").depots
    polys = area_polygons(dep)
    assert_allclose([_poly_area(p) for p in polys], EXAMPLE_AREAS_M2, atol=1.0)
    for i, poly in enumerate(polys):  # counter-clockwise rings, each around its own depot
        ring = np.array(poly)
        assert _signed_area(ring) > 0
        c = ring.mean(axis=0)
        assert dep.assign(c[:1], c[1:])[0] == i


def test_one_depot_holds_the_square() -> None:
    xy = np.array([[100.0, -200.0]])
    dep = Depots("kmeans", FRAME, xy, np.zeros(1, dtype=int), nearest_candidates(xy, 1))
    (poly,) = area_polygons(dep)
    assert_allclose(_poly_area(poly), 10_000.0**2, rtol=1e-12)


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        (lambda d: d.__setitem__("note", "by hand"), "'note'"),
        (lambda d: d["depots"][1].__setitem__("x-m", 5.0), r"'depots\[1\]\.x-m'"),
    ],
    ids=["top", "depot"],
)
def test_a_depots_file_s_unknown_key_is_refused(tmp_path, edit, key) -> None:
    """docs/config.md: an unknown key stops the run (a typo must not read as absent)."""
    xy = np.array([[0.0, 0.0], [2000.0, 0.0], [0.0, 3000.0]])
    doc = Depots("kmeans", FRAME, xy, np.array([5, 6, 7]), nearest_candidates(xy, 2)).to_dict({})
    path = tmp_path / "depots.json"
    path.write_text(json.dumps(doc))
    assert len(Depots.load(path)) == 3  # as written, it loads
    edit(doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=rf"depots\.json, key {key}: unknown key"):
        Depots.load(path)


def test_a_depot_moved_in_degrees_alone_is_refused(tmp_path) -> None:
    """x_m/y_m place a depot; lng/lat edited alone would be ignored, so they must agree."""
    xy = np.array([[0.0, 0.0], [2000.0, 0.0], [0.0, 3000.0]])
    doc = Depots("kmeans", FRAME, xy, np.array([5, 6, 7]), nearest_candidates(xy, 2)).to_dict({})
    path = tmp_path / "depots.json"
    for d in doc["depots"]:  # lng/lat are optional
        d.pop("lng"), d.pop("lat")
    path.write_text(json.dumps(doc))
    assert np.array_equal(Depots.load(path).xy, xy)
    doc = Depots("kmeans", FRAME, xy, np.array([5, 6, 7]), nearest_candidates(xy, 2)).to_dict({})
    doc["depots"][2]["lat"] += 0.01  # about 1.1 km north
    path.write_text(json.dumps(doc))
    says = r"key 'depots\[2\]\.lng': depot 2's lng/lat lie 1,1\d\d m"
    with pytest.raises(InputError, match=says):
        Depots.load(path)


def test_a_study_area_placed_away_from_the_requests_names_center(points_table) -> None:
    """--center where no request is: the one line says where the square is and which
    option moves it."""
    from marops_cli.config import PlannerConfig, override
    from marops_cli.segment.run import segment_table

    table = points_table([121.47, 121.48], [31.23, 31.24], "abc")
    cfg = override(PlannerConfig(), data__center=(0.5, 0.5))
    with pytest.raises(InputError, match=r"around 0\.50000, 0\.50000.*--center"):
        segment_table(table, cfg)


def _two_towns(example_csv, tmp_path, km: float):
    """300 rows of the example moved onto two points ``km`` apart (east-west)."""

    def place(k: int) -> tuple[float, float]:
        return 121.47 + (km / 95.0 if k % 2 else 0.0) + 0.00001 * (k % 5), 31.23

    return moved_example(example_csv, tmp_path / "towns.csv", place)


def test_a_depot_between_two_towns_is_a_warning_naming_n_depots(example_csv, tmp_path) -> None:
    """k-means' one centroid between two towns 8 km apart serves neither: segment warns,
    naming the options that place depots where the requests are; two depots are quiet."""
    import warnings

    from marops_cli.app.segment import segment
    from marops_cli.config import PlannerConfig, override

    data = _two_towns(example_csv, tmp_path, 8.0)
    cfg = override(PlannerConfig(), segment__n_depots=1, segment__n_actions=1)
    with pytest.warns(UserWarning, match=r"depot 0 lies more than 2 km .*4\.0 km.*--n-depots"):
        segment(data, cfg)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        segment(data, override(cfg, segment__n_depots=2))


def test_areas_across_the_antimeridian_are_cut_there_in_geojson() -> None:
    """A service area across 180° is a MultiPolygon of its parts on either side (RFC
    7946), never a ring jumping round the globe; areas elsewhere stay Polygons."""
    from marops_cli.segment import areas_geojson

    xy = np.array([[-2000.0, 0.0], [2000.0, 0.0]])
    for center, crossing in ((179.99, True), (121.47, False)):
        dep = Depots(
            "kmeans",
            Frame(center, -16.8, 10.0),
            xy,
            np.array([1, 1]),
            np.array([[0], [1]]),
        )
        areas = [
            f
            for f in areas_geojson(dep, {})["features"]
            if f["properties"]["kind"] == "service_area"
        ]
        kinds = [f["geometry"]["type"] for f in areas]
        assert kinds == (["Polygon", "MultiPolygon"] if crossing else ["Polygon", "Polygon"])
        for f in areas:
            polys = f["geometry"]["coordinates"]
            for poly in polys if f["geometry"]["type"] == "MultiPolygon" else [polys]:
                lngs = [c[0] for c in poly[0]]
                assert min(lngs) >= -180 and max(lngs) <= 180 and max(lngs) - min(lngs) < 1

"""Synthetic LaDe-D delivery exports that a reader cannot tell from a real one (docs/method.md §1).

The city is a square of ``extent_km`` around its centre. A few dense downtown
hubs hold many small, busy AOIs; the rest of the city holds sparse, larger AOIs.
AOIs belong to regions of a ``region_km`` grid, and every region has its own
couriers. Each day's volume follows the weekday with lognormal noise; delivery
times peak in the morning and afternoon, with a few night drops (so some
packages were accepted the day before); every package is accepted 0.3–6 h
before its delivery. Then the quirks of real exports are mixed in: bad
coordinates, exact duplicate rows, and delivery before accept.

``shape`` picks the city's layout (docs/method.md §1): ``hubs`` (the default above,
one demand profile everywhere), ``river`` (a band without addresses through the
centre; one bank busy in the morning, the other in the afternoon), ``corridor`` (a
long thin city whose peak moves along its axis) and ``polycentric`` (six centres
spread over the city, each with its own morning/afternoon mix). In the last three,
every AOI has its own share of morning deliveries, so demand moves over the map
during the day, as between business and residential districts.

The shipped example ``examples/shanghai_synth.csv`` (12 days, 2022-08-01 ..
2022-08-12) was made with the defaults::

    write(generate(SynthConfig(days=12, seed=7)), "examples/shanghai_synth.csv")
    # same as: marops synth --days 12 --seed 7 --out examples/shanghai_synth.csv
"""

from __future__ import annotations

import contextlib
import datetime as dt
import gzip
import io
import os
import tempfile
from pathlib import Path
from typing import Literal

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
from pydantic import BaseModel, ConfigDict, Field, model_validator

from .frame import Frame
from .settings import MAX_SEED
from .table import LADE_COLUMNS

# AOI type codes seen in LaDe (their meanings are unpublished) and how common each is.
_AOI_TYPES = np.array([1, 14, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 0, 15])
_AOI_TYPE_P = np.array([30, 14, 10, 8, 6, 5, 5, 4, 4, 3, 3, 2, 2, 2, 1, 1], dtype=float)
MAX_ORDERS_PER_DAY = 1_000_000
"""The most mean orders a day the generator makes: a day of 1,000,000 is about 150 MB of
CSV; far beyond, its 100,000 courier ids run out (one per ``orders_per_courier``)."""


class SynthConfig(BaseModel):
    """Everything that shapes a synthetic export; the same config gives the same bytes."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    days: int = Field(12, ge=1, le=366, description="number of consecutive days")
    seed: int = Field(7, ge=0, le=MAX_SEED, description="seed of numpy.random.default_rng")
    start: dt.date = Field(dt.date(2022, 8, 1), description="first delivery day")
    city: str = Field("Shanghai", description="value of the city column")
    shape: Literal["hubs", "river", "corridor", "polycentric"] = Field(
        "hubs", description="city layout and how demand moves over it during the day"
    )
    center_lng: float = Field(121.47, ge=-180, le=180, description="city centre longitude")
    center_lat: float = Field(31.23, ge=-80, le=80, description="city centre latitude")
    extent_km: float = Field(30.0, gt=0, le=200, description="side of the city square")
    n_hubs: int = Field(3, ge=1, description="dense downtown clusters")
    hub_spread_km: float = Field(3.0, ge=0, description="hub centres lie this close to the centre")
    hub_sigma_km: float = Field(1.0, gt=0, description="spread of AOIs around their hub")
    n_dense_aois: int = Field(200, ge=1, description="AOIs in the hubs")
    n_sparse_aois: int = Field(500, ge=0, description="AOIs spread over the whole city")
    dense_share: float = Field(0.22, ge=0, le=1, description="share of orders to hub AOIs")
    orders_per_day: float = Field(
        1800.0, gt=0, le=MAX_ORDERS_PER_DAY, description="mean city-wide orders per day"
    )
    weekday_factors: tuple[float, float, float, float, float, float, float] = Field(
        (1.05, 1.05, 1.0, 1.0, 1.02, 0.92, 0.86),
        description="volume factor Monday..Sunday",
    )
    daily_noise: float = Field(0.08, ge=0, description="sigma of the lognormal daily factor")
    region_km: float = Field(3.0, gt=0, description="side of a courier region")
    orders_per_courier: float = Field(45.0, gt=0, description="daily orders one courier takes")
    peak_hours: tuple[float, float] = Field((10.0, 15.0), description="morning/afternoon peak")
    peak_sd_h: tuple[float, float] = Field((0.9, 1.2), description="spread of each peak, hours")
    peak_shares: tuple[float, float] = Field(
        (0.45, 0.40), description="orders in each peak; the rest spread evenly over the day"
    )
    day_span_h: tuple[float, float] = Field((7.0, 20.0), description="span of daytime deliveries")
    night_share: float = Field(0.004, ge=0, le=1, description="deliveries outside day_span_h")
    accept_lead_h: tuple[float, float] = Field(
        (0.3, 6.0), description="accept happens this long before delivery"
    )
    gps_noise_m: float = Field(25.0, ge=0, description="sigma of the delivery GPS fix")
    accept_gps_noise_m: float = Field(300.0, ge=0, description="sigma of the accept GPS fix")
    gps_missing_rate: float = Field(0.04, ge=0, le=1, description="rows with no GPS fix")
    bad_coord_rate: float = Field(0.003, ge=0, le=1, description="rows with lng/lat 0 or empty")
    duplicate_rate: float = Field(0.005, ge=0, le=1, description="rows repeated verbatim")
    reversed_rate: float = Field(0.001, ge=0, le=1, description="rows delivered before accept")

    @model_validator(mode="after")
    def _check(self) -> SynthConfig:
        if sum(self.peak_shares) + self.night_share > 1:
            raise ValueError("expected peak_shares + night_share <= 1")
        if not 0 <= self.day_span_h[0] < self.day_span_h[1] <= 24:
            raise ValueError("expected 0 <= day_span_h[0] < day_span_h[1] <= 24")
        if not 0 < self.accept_lead_h[0] <= self.accept_lead_h[1]:
            raise ValueError("expected 0 < accept_lead_h[0] <= accept_lead_h[1]")
        return self


def _city(cfg: SynthConfig, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """AOIs (centre, radius, popularity, ids) and the couriers of their regions, in metres."""
    half = cfg.extent_km * 500.0
    ang = rng.uniform(0, 2 * np.pi, cfg.n_hubs)
    rad = cfg.hub_spread_km * 1000.0 * np.sqrt(rng.uniform(0, 1, cfg.n_hubs))
    hubs = np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
    hub_of = rng.choice(cfg.n_hubs, cfg.n_dense_aois, p=rng.dirichlet(np.full(cfg.n_hubs, 3.0)))
    dense_xy = hubs[hub_of] + rng.normal(0, cfg.hub_sigma_km * 1000.0, (cfg.n_dense_aois, 2))
    sparse_xy = rng.uniform(-half, half, (cfg.n_sparse_aois, 2))
    xy = np.clip(np.vstack([dense_xy, sparse_xy]), -half, half)
    n = xy.shape[0]
    dense = np.arange(n) < cfg.n_dense_aois
    shaped: dict[str, np.ndarray] = {}  # each AOI's morning share, for the shaped cities
    if cfg.shape != "hubs":  # its own random stream: the default city keeps its bytes
        xy, shaped["morning"] = _shape(cfg, np.random.default_rng([cfg.seed, 1]), xy, dense, hub_of)
    # Small busy compounds downtown, larger quiet neighbourhoods elsewhere.
    r_lo, r_hi = (
        np.where(dense, np.log(80), np.log(200)),
        np.where(dense, np.log(300), np.log(1000)),
    )
    radius = np.exp(rng.uniform(r_lo, r_hi))
    w = rng.lognormal(0, np.where(dense, 0.8, 1.0))
    share = cfg.dense_share if cfg.n_sparse_aois else 1.0
    sums = w[dense].sum(), max(w[~dense].sum(), 1e-12)
    weight = np.where(dense, share * w / sums[0], (1 - share) * w / sums[1])
    weight /= weight.sum()
    aoi_id = rng.choice(20_000, n, replace=False)
    aoi_type = rng.choice(_AOI_TYPES, n, p=_AOI_TYPE_P / _AOI_TYPE_P.sum())

    # Regions are cells of a grid; ids are shuffled so they carry no geography.
    k = max(1, int(np.ceil(cfg.extent_km / cfg.region_km)))
    cell_size = 2 * half / k
    cell = np.minimum((xy + half) // cell_size, k - 1).astype(np.int64)
    cells, region_idx = np.unique(cell[:, 1] * k + cell[:, 0], return_inverse=True)
    region_id = rng.permutation(np.arange(1, len(cells) + 1))
    volume = np.bincount(region_idx, weights=weight, minlength=len(cells)) * cfg.orders_per_day
    n_couriers = np.maximum(1, np.round(volume / cfg.orders_per_courier)).astype(np.int64)
    courier_ids = rng.choice(100_000, int(n_couriers.sum()), replace=False) + 1
    first = np.concatenate([[0], np.cumsum(n_couriers)[:-1]])
    return {
        "xy": xy, "radius": radius, "weight": weight, "aoi_id": aoi_id, "aoi_type": aoi_type,
        "region_idx": region_idx, "region_id": region_id, "n_couriers": n_couriers,
        "first_courier": first, "courier_ids": courier_ids, **shaped,
    }  # fmt: skip


def _shape(
    cfg: SynthConfig,
    rng: np.random.Generator,
    xy: np.ndarray,
    dense: np.ndarray,
    hub_of: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """AOI positions moved into ``cfg.shape``'s layout, and each AOI's morning share of
    its peak-hour deliveries."""
    half = cfg.extent_km * 500.0
    n = xy.shape[0]
    if cfg.shape == "river":
        # A band 1.5 km wide at a random angle through the centre holds no address; AOIs
        # in it move to the nearer bank. One bank works mornings, the other afternoons.
        ang = rng.uniform(0, np.pi)
        normal = np.array([-np.sin(ang), np.cos(ang)])
        off = xy @ normal
        side = np.where(off >= 0, 1.0, -1.0)
        inside = np.abs(off) < 750.0
        xy = xy + np.where(inside, (750.0 - np.abs(off)) * side, 0.0)[:, None] * normal
        morning = np.where(side > 0, 0.8, 0.2) + rng.normal(0, 0.05, n)
    elif cfg.shape == "corridor":
        # A city 3.5 times longer than wide along a random axis; mornings at one end.
        ang = rng.uniform(0, np.pi)
        u = np.array([np.cos(ang), np.sin(ang)])
        v = np.array([-u[1], u[0]])
        along, across = xy @ u, 0.3 * (xy @ v)
        xy = along[:, None] * u + across[:, None] * v
        morning = 0.5 + 0.35 * along / half + rng.normal(0, 0.05, n)
    else:  # polycentric: six centres over the whole city, each with its own rhythm
        k = 6
        centres = rng.uniform(-0.7 * half, 0.7 * half, (k, 2))
        mix = rng.uniform(0.15, 0.85, k)
        who = np.asarray(rng.integers(0, k, size=n), dtype=np.int64)
        who[dense] = hub_of % k
        sigma = np.where(dense, cfg.hub_sigma_km * 1000.0, 0.35 * half)
        xy = centres[who] + rng.normal(0, 1, (n, 2)) * sigma[:, None]
        morning = mix[who] + rng.normal(0, 0.05, n)
    return np.clip(xy, -half, half), np.clip(morning, 0.05, 0.95)


def _delivery_hours(
    cfg: SynthConfig, rng: np.random.Generator, n: int, morning: np.ndarray | None = None
) -> np.ndarray:
    """Hour of day of each delivery: two normal peaks over an even background, plus a
    few night drops outside ``day_span_h`` (lockers), which were accepted the day before.
    ``morning`` (per delivery) splits the peak deliveries between the two peaks; None
    keeps ``peak_shares``."""
    lo, hi = cfg.day_span_h
    p = np.array([*cfg.peak_shares, 0.0, cfg.night_share])
    p[2] = max(0.0, 1.0 - p.sum())
    if morning is None:
        comp = rng.choice(4, n, p=p / p.sum())
    else:
        peak = p[0] + p[1]
        cum = (
            np.column_stack(
                [peak * morning, np.full(n, peak), np.full(n, peak + p[2]), np.full(n, p.sum())]
            )
            / p.sum()
        )
        comp = np.minimum((rng.random(n)[:, None] >= cum).sum(axis=1), 3)
    mu = np.array(cfg.peak_hours)[np.minimum(comp, 1)]
    sd = np.array(cfg.peak_sd_h)[np.minimum(comp, 1)]
    hours = np.where(comp < 2, rng.normal(mu, sd), rng.uniform(lo, hi, n))
    # A tail beyond the working day is redrawn evenly rather than piled on the edges.
    out = (comp < 2) & ((hours < lo) | (hours >= hi))
    hours[out] = rng.uniform(lo, hi, int(out.sum()))
    night = comp == 3
    hours[night] = (hi + rng.uniform(0, 24 - hi + lo, int(night.sum()))) % 24
    return hours


def _lnglat_cols(frame: Frame, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lng, lat = frame.to_lnglat(x, y)
    return np.round(lng, 6), np.round(lat, 6)


def _times(seconds: np.ndarray, missing: np.ndarray | None = None) -> pa.Array:
    """Naive local seconds -> ``MM-DD HH:MM:SS`` strings (null where ``missing``)."""
    ts = pa.array(seconds.astype(np.int64), type=pa.int64(), mask=missing).cast(pa.timestamp("s"))
    return pc.strftime(ts, format="%m-%d %H:%M:%S")


def generate(cfg: SynthConfig | None = None) -> pa.Table:
    """A LaDe-D delivery export as an Arrow table: the 17 columns in file order."""
    cfg = cfg or SynthConfig()
    rng = np.random.default_rng(cfg.seed)
    city = _city(cfg, rng)
    frame = Frame(cfg.center_lng, cfg.center_lat, cfg.extent_km)

    day0 = np.datetime64(cfg.start, "D")
    weekday = (np.arange(cfg.days) + cfg.start.weekday()) % 7
    mean = cfg.orders_per_day * np.array(cfg.weekday_factors)[weekday]
    per_day = rng.poisson(mean * rng.lognormal(0, cfg.daily_noise, cfg.days))
    day = np.repeat(np.arange(cfg.days), per_day)
    n = int(day.size)

    aoi = rng.choice(len(city["weight"]), n, p=city["weight"])
    r = city["radius"][aoi] * np.sqrt(rng.uniform(0, 1, n))
    th = rng.uniform(0, 2 * np.pi, n)
    x = city["xy"][aoi, 0] + r * np.cos(th)
    y = city["xy"][aoi, 1] + r * np.sin(th)
    region = city["region_idx"][aoi]
    courier = city["courier_ids"][
        city["first_courier"][region] + rng.integers(0, city["n_couriers"][region])
    ]

    midnight = (day0 + day).astype("datetime64[s]").astype(np.int64)
    morning = city["morning"][aoi] if "morning" in city else None  # None: peak_shares
    hours = _delivery_hours(cfg, rng, n, morning)
    delivery_s = midnight + np.round(hours * 3600).astype(np.int64)
    lo, hi = (h * 3600 for h in cfg.accept_lead_h)
    lead = lo + (hi - lo) * rng.beta(1.5, 3.0, n)
    accept_s = delivery_s - np.clip(np.round(lead), np.ceil(lo), np.floor(hi)).astype(np.int64)
    # GPS fixes lag the scan by up to two minutes and are sometimes lost altogether.
    acc_gps_s = accept_s - rng.integers(0, 121, n)
    del_gps_s = delivery_s - rng.integers(0, 121, n)
    acc_miss = rng.random(n) < cfg.gps_missing_rate
    del_miss = rng.random(n) < cfg.gps_missing_rate
    acc_gx = x + rng.normal(0, cfg.accept_gps_noise_m, n)
    acc_gy = y + rng.normal(0, cfg.accept_gps_noise_m, n)
    del_gx = x + rng.normal(0, cfg.gps_noise_m, n)
    del_gy = y + rng.normal(0, cfg.gps_noise_m, n)
    order_id = rng.permutation(1 + np.cumsum(rng.integers(1, 40, n)))

    # Couriers' stops in delivery order, day by day, as the export lists them.
    order = np.lexsort((delivery_s, courier, city["region_id"][region], day))
    pick = {
        "order_id": order_id, "region_id": city["region_id"][region], "courier_id": courier,
        "x": x, "y": y, "aoi_id": city["aoi_id"][aoi], "aoi_type": city["aoi_type"][aoi],
        "accept_s": accept_s, "acc_gps_s": acc_gps_s, "acc_gx": acc_gx, "acc_gy": acc_gy,
        "delivery_s": delivery_s, "del_gps_s": del_gps_s, "del_gx": del_gx, "del_gy": del_gy,
        "acc_miss": acc_miss, "del_miss": del_miss,
    }  # fmt: skip
    c = {k: v[order] for k, v in pick.items()}

    # Quirks land on distinct rows so each can be counted on its own.
    perm = rng.permutation(n)
    k_bad, k_rev, k_dup = (
        int(rng.binomial(n, rate))
        for rate in (cfg.bad_coord_rate, cfg.reversed_rate, cfg.duplicate_rate)
    )
    bad = perm[:k_bad]
    rev = perm[k_bad : k_bad + k_rev]
    dup = perm[k_bad + k_rev : k_bad + k_rev + k_dup]
    shift = np.round(rng.uniform(0.1, 3.0, k_rev) * 3600).astype(np.int64)
    c["accept_s"][rev] = c["delivery_s"][rev] + shift
    c["acc_gps_s"][rev] = c["accept_s"][rev] - rng.integers(0, 121, k_rev)

    lng, lat = _lnglat_cols(frame, c["x"], c["y"])
    zero = rng.random(k_bad) < 0.5
    lng[bad[zero]] = lat[bad[zero]] = 0.0
    coord_null = np.zeros(n, dtype=bool)
    coord_null[bad[~zero]] = True
    acc_lng, acc_lat = _lnglat_cols(frame, c["acc_gx"], c["acc_gy"])
    del_lng, del_lat = _lnglat_cols(frame, c["del_gx"], c["del_gy"])

    dates = (c["delivery_s"] // 86_400).astype("datetime64[D]")
    months = dates.astype("datetime64[M]")
    ds = (months.astype(np.int64) % 12 + 1) * 100 + (dates - months).astype(np.int64) + 1

    am, dm = c["acc_miss"], c["del_miss"]
    cols = {
        "order_id": pa.array(c["order_id"], pa.int64()),
        "region_id": pa.array(c["region_id"], pa.int64()),
        "city": pa.array(np.full(n, cfg.city, dtype=object), pa.string()),
        "courier_id": pa.array(c["courier_id"], pa.int64()),
        "lng": pa.array(lng, pa.float64(), mask=coord_null),
        "lat": pa.array(lat, pa.float64(), mask=coord_null),
        "aoi_id": pa.array(c["aoi_id"], pa.int64()),
        "aoi_type": pa.array(c["aoi_type"], pa.int64()),
        "accept_time": _times(c["accept_s"]),
        "accept_gps_time": _times(c["acc_gps_s"], am),
        "accept_gps_lng": pa.array(acc_lng, pa.float64(), mask=am),
        "accept_gps_lat": pa.array(acc_lat, pa.float64(), mask=am),
        "delivery_time": _times(c["delivery_s"]),
        "delivery_gps_time": _times(c["del_gps_s"], dm),
        "delivery_gps_lng": pa.array(del_lng, pa.float64(), mask=dm),
        "delivery_gps_lat": pa.array(del_lat, pa.float64(), mask=dm),
        "ds": pa.array(ds, pa.int64()),
    }
    table = pa.table({name: cols[name] for name in LADE_COLUMNS})
    # A duplicate sits right after its original, as a repeated upload would.
    rows = np.sort(np.concatenate([np.arange(n), dup]), kind="stable")
    return table.take(pa.array(rows))


def file_format(path: str | os.PathLike[str]) -> tuple[Literal["csv", "parquet"], bool]:
    """(format, gzipped) told by a path's suffixes: ``.parquet``/``.pq`` -> Parquet, else
    CSV; a last suffix ``.gz`` is gzip around the format its suffix before tells."""
    suffixes = [s.lower() for s in Path(path).suffixes]
    gzipped = suffixes[-1:] == [".gz"]
    base = suffixes[-2:-1] if gzipped else suffixes[-1:]
    return ("parquet" if base in ([".parquet"], [".pq"]) else "csv"), gzipped


def write(
    table: pa.Table,
    path: str | os.PathLike[str],
    format: Literal["csv", "parquet"] | None = None,
    *,
    gzipped: bool | None = None,
) -> Path:
    """Write ``table`` atomically as CSV (unquoted, like LaDe) or Parquet; returns the path.

    ``format`` and ``gzipped`` default to what the path's suffixes tell (:func:`file_format`).
    Gzipped CSV has no time or name in its gzip header: the same table, the same bytes.
    Parquet compresses its own columns and is never gzipped. The file appears complete or
    not at all: it is written beside its target and then renamed over it.
    """
    path = Path(path)
    suffix_fmt, suffix_gz = file_format(path)
    fmt = format or suffix_fmt
    gzipped = suffix_gz if gzipped is None else gzipped
    if fmt not in ("csv", "parquet"):
        raise ValueError(f"expected format 'csv' or 'parquet', got {fmt!r}")
    if fmt == "parquet" and gzipped:
        raise ValueError(f"{path}: Parquet is not gzipped; drop the .gz")
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as raw:
            if fmt == "parquet":
                pq.write_table(table, raw, compression="zstd")
            elif gzipped:
                # Level 6, gzip's own default: 9 took 2.6 times as long for a file 1 % smaller.
                gz = gzip.GzipFile(filename="", mode="wb", fileobj=raw, compresslevel=6, mtime=0)
                with gz as fh:
                    _write_csv(table, fh)
            else:
                _write_csv(table, raw)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    return path


def _write_csv(table: pa.Table, fh: io.BufferedIOBase) -> None:
    """``table`` as CSV into ``fh``: unquoted, like LaDe."""
    # pyarrow quotes header names whatever the quoting style; LaDe does not.
    fh.write((",".join(table.column_names) + "\n").encode())
    opts = pacsv.WriteOptions(include_header=False, quoting_style="none")
    pacsv.write_csv(table, fh, opts)

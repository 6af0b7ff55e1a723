"""Time ``read_lade`` on a 1.5-million-row LaDe-shaped CSV (the size of delivery_sh.csv).

Usage::

    python benchmarks/read_lade.py [PATH] [--rows N] [--keep] [--smoke]

Writes the CSV (to PATH, or a temporary folder removed afterwards), then reads it
in a fresh subprocess so that generating the file does not count, and prints the
read's wall seconds, the child's peak RSS (``ru_maxrss``) and the drop report.
Target: under 10 s and 2 GB on 2 cores. ``--smoke`` writes and reads 20,000 rows (CI
runs it so the script keeps up with the library).
"""

from __future__ import annotations

import os
import sys

# Run as a script, this folder comes first on sys.path, where a sibling module may
# shadow the standard library (a module named select.py would hide `select`, which
# subprocess imports). The script needs nothing from its own folder.
if sys.path and os.path.abspath(sys.path[0]) == os.path.dirname(os.path.abspath(__file__)):
    sys.path.pop(0)

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pyarrow as pa  # noqa: E402
import pyarrow.compute as pc  # noqa: E402
import pyarrow.csv as pacsv  # noqa: E402

_CHILD = """
import json, resource, sys, time
from marops_cli.config import DataConfig
from marops_cli.data.reader import read_lade
t0 = time.perf_counter()
table = read_lade(sys.argv[1], DataConfig())
wall = time.perf_counter() - t0
rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB on Linux
print(json.dumps({"wall_s": wall, "peak_rss_mb": rss_mb, "kept": len(table),
                  "report": table.report.to_dict()}))
"""


def _times(seconds: np.ndarray) -> pa.Array:
    """Naive seconds since 1970 -> ``MM-DD HH:MM:SS`` strings, as LaDe writes them."""
    ts = pa.array(seconds.astype("datetime64[s]"))
    return pc.strftime(ts, format="%m-%d %H:%M:%S")


def _blank(arr: pa.Array, mask: np.ndarray) -> pa.Array:
    return pc.if_else(pa.array(mask), pa.scalar(None, arr.type), arr)


def make_csv(path: Path, rows: int, seed: int = 0) -> None:
    """Write a LaDe-shaped CSV with ~1 % bad rows (0 / empty coordinates, duplicates,
    delivery before accept, empty times)."""
    rng = np.random.default_rng(seed)
    n = rows
    day0 = np.datetime64("2022-05-01", "s").astype(np.int64)
    day = rng.integers(0, 184, n)  # 2022-05-01 .. 2022-10-31
    due_in_day = rng.normal(14 * 3600, 3 * 3600, n).clip(7 * 3600, 21 * 3600).astype(np.int64)
    delivery = day0 + day * 86_400 + due_in_day
    accept = delivery - rng.integers(1800, 6 * 3600, n)
    hub = rng.integers(0, 3, n)
    lng = 121.47 + 0.03 * (hub - 1) + rng.normal(0, 0.04, n)
    lat = 31.23 + 0.02 * (hub - 1) + rng.normal(0, 0.03, n)
    order_id = rng.permutation(n * 2)[:n]
    # Duplicates: copy earlier rows over later positions (~0.3 %).
    dup = rng.random(n) < 0.003
    src = (np.flatnonzero(dup) * rng.random(dup.sum())).astype(np.int64)
    for a in (delivery, accept, lng, lat, order_id, day):
        a[dup] = a[src]
    swap = rng.random(n) < 0.002  # delivery before accept
    accept[swap], delivery[swap] = delivery[swap], accept[swap]
    lng_s = pc.round(pa.array(lng), 6).cast(pa.string())
    lat_s = pc.round(pa.array(lat), 6).cast(pa.string())
    zero = rng.random(n) < 0.003
    lng_s = pc.if_else(pa.array(zero), "0.0", lng_s)
    lat_s = pc.if_else(pa.array(zero), "0.0", lat_s)
    lng_s = _blank(lng_s, rng.random(n) < 0.001)
    acc_s = _blank(_times(accept), rng.random(n) < 0.001)
    del_s = _blank(_times(delivery), rng.random(n) < 0.0005)
    ds = pc.strftime(pa.array(delivery.astype("datetime64[s]")), format="%m%d").cast(pa.int32())
    ints = lambda lo, hi: pa.array(rng.integers(lo, hi, n))  # noqa: E731
    table = pa.table(
        {
            "order_id": pa.array(order_id),
            "region_id": ints(0, 200),
            "city": pa.array(np.full(n, "Shanghai")),
            "courier_id": ints(0, 5000),
            "lng": lng_s,
            "lat": lat_s,
            "aoi_id": ints(0, 20000),
            "aoi_type": ints(0, 16),
            "accept_time": acc_s,
            "accept_gps_time": acc_s,
            "accept_gps_lng": lng_s,
            "accept_gps_lat": lat_s,
            "delivery_time": del_s,
            "delivery_gps_time": del_s,
            "delivery_gps_lng": lng_s,
            "delivery_gps_lat": lat_s,
            "ds": ds,
        }
    )
    pacsv.write_csv(table, path, pacsv.WriteOptions(quoting_style="none"))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", nargs="?", help="CSV to write and read (default: a temp file)")
    ap.add_argument("--rows", type=int, default=1_500_000)
    ap.add_argument("--keep", action="store_true", help="keep an existing file at PATH")
    ap.add_argument("--smoke", action="store_true", help="20,000 rows (CI)")
    args = ap.parse_args(argv)
    if args.smoke:
        args.rows = 20_000
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(args.path) if args.path else Path(tmp) / "delivery_bench.csv"
        if not (args.keep and path.exists()):
            t0 = time.perf_counter()
            make_csv(path, args.rows)
            print(
                f"wrote {args.rows:,} rows, {path.stat().st_size / 1e6:.0f} MB "
                f"in {time.perf_counter() - t0:.1f} s: {path}"
            )
        root = Path(__file__).resolve().parents[1]
        out = subprocess.run(
            [sys.executable, "-c", _CHILD, str(path)],
            check=True,
            capture_output=True,
            text=True,
            cwd=root,
        )
        res = json.loads(out.stdout)
    print(
        f"read_lade: {res['wall_s']:.2f} s wall, peak RSS {res['peak_rss_mb']:.0f} MB, "
        f"kept {res['kept']:,}"
    )
    print(f"report: {json.dumps(res['report'])}")


if __name__ == "__main__":
    main()

"""The bad-input corpus: awkward or broken files of every kind a command reads.

``python tests/bad_corpus.py DIR`` writes them to DIR; the test suite builds them in a
temporary folder (tests/test_bad_corpus.py) and runs each through every command that
reads that kind of file. Each entry is (kind, file name, what makes it bad).
"""

from __future__ import annotations

import gzip
import json
import sys
from collections.abc import Callable
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

HEADER = (
    "order_id,region_id,city,courier_id,lng,lat,aoi_id,aoi_type,accept_time,accept_gps_time,"
    "accept_gps_lng,accept_gps_lat,delivery_time,delivery_gps_time,delivery_gps_lng,"
    "delivery_gps_lat,ds"
)


def row(
    oid: object = 1,
    lng: str = "121.47",
    lat: str = "31.23",
    acc: str = "08-11 08:00:00",
    dlv: str = "08-11 10:00:00",
    ds: str = "811",
) -> str:
    return f"{oid},1,Shanghai,7,{lng},{lat},5,1,{acc},,,,{dlv},,,,{ds}"


def _rows(n: int = 40, **bad_at_7: str) -> list[str]:
    out = [
        row(i, lng=f"{121.40 + 0.002 * i:.4f}", lat=f"{31.20 + 0.001 * i:.4f}") for i in range(n)
    ]
    if bad_at_7:
        out[7] = row(**{"oid": 7, **bad_at_7})
    return out


def _csv(lines: list[str]) -> Callable[[Path], None]:
    return lambda p: p.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _bytes(data: bytes) -> Callable[[Path], None]:
    return lambda p: p.write_bytes(data)


def _parquet(columns: dict[str, list[object]]) -> Callable[[Path], None]:
    return lambda p: pq.write_table(pa.table(columns), p)


def _json(doc: object) -> Callable[[Path], None]:
    return lambda p: p.write_text(json.dumps(doc), encoding="utf-8")


def _text(text: str) -> Callable[[Path], None]:
    return lambda p: p.write_text(text, encoding="utf-8")


GOOD_PQ = {
    "order_id": [str(i) for i in range(40)],
    "lng": [121.40 + 0.002 * i for i in range(40)],
    "lat": [31.20 + 0.001 * i for i in range(40)],
    "accept_time": ["08-11 08:00:00"] * 40,
    "delivery_time": ["08-11 10:00:00"] * 40,
}

# kind -> name -> writer. Names carry the suffix the command sees.
DATA: dict[str, Callable[[Path], None]] = {
    "missing_lat.csv": _csv([HEADER.replace(",lat,", ",latitude,"), *_rows()]),
    "missing_delivery_time.csv": _csv([HEADER.replace(",delivery_time,", ",dt,"), *_rows()]),
    "time_25h.csv": _csv([HEADER, *_rows(dlv="08-11 25:99:00")]),
    "time_feb30.csv": _csv([HEADER, *_rows(acc="02-30 08:00:00")]),
    "time_words.csv": _csv([HEADER, *_rows(dlv="tomorrow")]),
    "ds_bad.csv": _csv([HEADER, *_rows(ds="8x1")]),
    "empty_order_id.csv": _csv([HEADER, *_rows(oid="")]),
    "header_only.csv": _csv([HEADER]),
    "empty.csv": _text(""),
    "not_lade.csv": _csv(["hello,world", "1,2"]),
    "binary.csv": _bytes(bytes(range(256)) * 8),
    "latin1.csv": _bytes(
        ("\n".join([HEADER, *_rows()[:5], row(99, lng="121,47é")]) + "\n").encode("latin-1")
    ),
    "ragged.csv": _csv([HEADER, *_rows()[:5], "1,2,3"]),
    "garbage.csv.gz": _bytes(b"\x1f\x8b\x08" + b"not really gzip" * 10),
    "truncated.csv.gz": _bytes(gzip.compress(("\n".join([HEADER, *_rows()])).encode())[:60]),
    "garbage.parquet": _bytes(b"PAR1" + b"\x00" * 50),
    "missing_column.parquet": _parquet({k: v for k, v in GOOD_PQ.items() if k != "lng"}),
    "bad_time.parquet": _parquet({**GOOD_PQ, "delivery_time": ["08-11 10:00:00"] * 39 + ["soon"]}),
    "no_rows.parquet": _parquet({k: [] for k in GOOD_PQ}),
    "bad_weight.csv": _csv(
        [HEADER + ",weight_kg", *[r + ",0.5" for r in _rows()[:7]], row(7) + ",-1"]
    ),
    "all_out_of_day.csv": _csv([HEADER, *(row(i, dlv="08-12 03:00:00") for i in range(20))]),
    "comma_decimals.csv": _csv([HEADER, *_rows(lng="121,47")]),
    "only_bad_rows_strict.csv": _csv([HEADER, *(row(i, lng="0", lat="0") for i in range(10))]),
    "world.csv": _csv(
        [HEADER]
        + [row(i, lng=f"{-170 + 8.5 * i:.3f}", lat=f"{-60 + 3 * i:.3f}") for i in range(40)]
    ),
}
CONFIG: dict[str, Callable[[Path], None]] = {
    "not_toml.toml": _text("[plan\nalpha = "),
    "unknown_key.toml": _text("[plan]\nalphaa = 0.5\n"),
    "bad_value.toml": _text('[plan]\nalpha = "half"\n'),
    "out_of_range.toml": _text("[plan]\nalpha = 7\n"),
    "unknown_stage.toml": _text("[planner]\nalpha = 0.5\n"),
    "bad_tz.toml": _text('[data]\ntz = "Mars/Olympus"\n'),
    "bad_hours.toml": _text('[data]\nservice_start = "25:00"\n'),
}
FRAME = {"center_lng": 121.44, "center_lat": 31.22, "size_km": 10.0}
DEPOT = {"id": 0, "x_m": 0.0, "y_m": 0.0, "lng": 121.44, "lat": 31.22, "n_history": 3}
DEPOTS: dict[str, Callable[[Path], None]] = {
    "not_json.json": _text("{bad"),
    "a_list.json": _json([1, 2]),
    "no_frame.json": _json({"depots": [DEPOT], "candidates": {"0": [0]}}),
    "no_depots.json": _json({"frame": FRAME, "depots": [], "candidates": {}}),
    "nan_position.json": _text(
        json.dumps({"frame": FRAME, "depots": [DEPOT], "candidates": {"0": [0]}}).replace(
            '"x_m": 0.0', '"x_m": NaN'
        )
    ),
    "unknown_candidate.json": _json(
        {"frame": FRAME, "depots": [DEPOT], "candidates": {"0": [0, 5]}}
    ),
    "not_self_first.json": _json(
        {
            "frame": FRAME,
            "depots": [DEPOT, {**DEPOT, "id": 1, "x_m": 500.0}],
            "candidates": {"0": [1, 0], "1": [1, 0]},
        }
    ),
    "bad_frame.json": _json(
        {"frame": {**FRAME, "center_lat": 123.0}, "depots": [DEPOT], "candidates": {"0": [0]}}
    ),
}
SIDE = {"obs_version": 3, "n_actions": 4, "hidden_size": 64}
POLICY: dict[str, Callable[[Path], None]] = {
    "no_sidecar.pt": _bytes(b"PK\x03\x04not torchscript"),
    "not_torchscript.pt": _bytes(b"PK\x03\x04not torchscript"),
    "bad_sidecar_json.pt": _bytes(b"x"),
    "sidecar_lacks_field.pt": _bytes(b"x"),
    "sidecar_text_version.pt": _bytes(b"x"),
    "sidecar_old_version.pt": _bytes(b"x"),
}
SIDECARS: dict[str, Callable[[Path], None]] = {
    "not_torchscript.json": _json(SIDE),
    "bad_sidecar_json.json": _text("{"),
    "sidecar_lacks_field.json": _json({"obs_version": 3, "n_actions": 4}),
    "sidecar_text_version.json": _json({**SIDE, "obs_version": "three"}),
    "sidecar_old_version.json": _json({**SIDE, "obs_version": 1}),
}
FLEET: dict[str, Callable[[Path], None]] = {
    "fleet_not_json.json": _text("[1, 2"),
    "fleet_unknown_depot.json": _json([0, 99]),
    "fleet_negative.json": _json([-1]),
    "fleet_words.json": _json(["north"]),
    "fleet_empty.json": _json([]),
}
KINDS = {"data": DATA, "config": CONFIG, "depots": DEPOTS, "policy": POLICY, "fleet": FLEET}


def write_corpus(folder: Path) -> dict[str, dict[str, Path]]:
    """Every bad file under ``folder/<kind>/``; returns kind -> name -> path."""
    out: dict[str, dict[str, Path]] = {}
    for kind, files in KINDS.items():
        sub = folder / kind
        sub.mkdir(parents=True, exist_ok=True)
        out[kind] = {}
        for name, write in files.items():
            write(sub / name)
            out[kind][name] = sub / name
    for name, write in SIDECARS.items():
        write(folder / "policy" / name)
    return out


if __name__ == "__main__":
    made = write_corpus(Path(sys.argv[1] if len(sys.argv) > 1 else "bad"))
    print(sum(len(v) for v in made.values()), "bad inputs")

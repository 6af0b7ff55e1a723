"""The bad-input corpus: awkward or broken files of every kind a command reads.

``python tests/bad_corpus.py DIR`` writes them to DIR; the test suite builds them in a
temporary folder (tests/test_bad_corpus.py) and runs each through every command that
reads that kind of file. Each entry is (kind, file name, what makes it bad).
"""

from __future__ import annotations

import gzip
import json
import os
import pickle
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


def _pipe(p: Path) -> None:
    """A named pipe nobody writes to: opening it for reading would block for ever."""
    os.mkfifo(p)


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
    # Most lines of another number of fields: no LaDe layout (one such line is dropped).
    "ragged.csv": _csv([HEADER, *_rows()[:5], *["1,2,3"] * 6]),
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
    "comma_decimals.csv": _csv([HEADER, *(r.replace(",121.", ",121,", 1) for r in _rows())]),
    "only_bad_rows_strict.csv": _csv([HEADER, *(row(i, lng="0", lat="0") for i in range(10))]),
    # An even count with no point at the median position: none within 150 km of it.
    "world_scattered.csv": _csv(
        [HEADER]
        + [row(i, lng=f"{-170.3 + 8.7 * i:.3f}", lat=f"{-60.3 + 3.1 * i:.3f}") for i in range(40)]
    ),
    "bool_lng.parquet": _parquet({**GOOD_PQ, "lng": [True] * 40}),
    "lng_twice.csv": _csv([HEADER + ",lng", *(r + ",0" for r in _rows())]),
    "all_nan_lng.csv": _csv([HEADER, *(row(i, lng="nan") for i in range(20))]),
    "header_no_line_end.csv": _text(HEADER),
    "header_field_200k.csv": _text("a" * 200_000 + "\n" + "1\n"),
    "order_id_lists.parquet": _parquet({**GOOD_PQ, "order_id": [[i] for i in range(40)]}),
    "lng_beyond_2_53.parquet": _parquet({**GOOD_PQ, "lng": [2**62] * 40}),
    "pipe.csv": _pipe,
    # Categorical (dictionary-encoded) columns: a text cell in a column of numbers.
    "dict_weight_text.parquet": lambda p: pq.write_table(
        pa.table(
            {
                **GOOD_PQ,
                "weight_kg": pa.array(["0.5"] * 7 + ["--"] + ["0.5"] * 32).dictionary_encode(),
            }
        ),
        p,
    ),
    # Latin-1 in city, which is not read (any bytes), and in aoi_id, which is.
    "latin1_aoi.csv": _bytes(
        (
            "\n".join(
                [
                    HEADER,
                    *(r.replace("Shanghai", "Sh\xe0ngh\xe0i") for r in _rows()[:3]),
                    row(3).replace(",5,1,08-11", ",\xe05,1,08-11"),
                ]
            )
            + "\n"
        ).encode("latin-1")
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
    # Impossible numbers (docs/config.md): each named by its key.
    "payload_inf.toml": _text("[energy]\nmax_payload_kg = inf\n"),
    "window_1e-9.toml": _text("[data]\nwindow_min = 1e-9\n"),
    "battery_inf.toml": _text("[energy]\nbattery_j = inf\n"),
    "speed_inf.toml": _text("[energy]\nspeed_ms = inf\n"),
    "weight_sigma_inf.toml": _text("[data]\nweight_sigma = inf\n"),
    "cda_inf.toml": _text("[energy]\ncda_m2 = inf\n"),
    "alpha_nan.toml": _text("[plan]\nalpha = nan\n"),
    "speed_supersonic.toml": _text("[energy]\nspeed_ms = 400.0\n"),
    "speed_subnormal.toml": _text("[energy]\nspeed_ms = 1e-310\n"),
    "efficiency_subnormal.toml": _text("[energy]\nefficiency = 5e-324\n"),
    "drones_100000.toml": _text("[sim]\ndrones = 100000\n"),
    "bound_labels_10.toml": _text("[plan]\nbound_labels = 10\n"),
    "center_off_earth.toml": _text("[data]\ncenter = [500.0, 31.2]\n"),
    # Crafted to break the parser itself: nesting beyond its recursion, a 5,000-digit number.
    "deep.toml": _text("x = " + "[" * 5000 + "]" * 5000 + "\n"),
    "huge_int.toml": _text("[sim]\ndrones = " + "1" * 5000 + "\n"),
    # What validation would convert quietly: a switch for a number, text for a number, a
    # number for a switch.
    "bool_drones.toml": _text("[sim]\ndrones = true\n"),
    "text_year.toml": _text('[data]\nyear = "2022"\n'),
    "number_bound.toml": _text("[plan]\nbound = 1\n"),
    "stage_array.toml": _text("[[plan]]\nalpha = 0.5\n"),
    "center_text.toml": _text('[data]\ncenter = ["121.44", "31.22"]\n'),
    "center_bools.toml": _text("[data]\ncenter = [true, false]\n"),
    # Inside the old ranges yet impossible: a delay price (1 - alpha)/alpha that overflows,
    # a rotor disc whose area underflows to 0, a zone name too long to look up.
    "alpha_1e-300.toml": _text("[plan]\nalpha = 1e-300\n"),
    "rotor_1e-300.toml": _text("[energy]\nrotor_diameter_m = 1e-300\n"),
    "tz_too_long.toml": _text('[data]\ntz = "' + "A" * 5000 + '"\n'),
    "pipe.toml": _pipe,
    # A policy that is neither a name nor an actor file's path: named with its key.
    "policy_unknown.toml": _text('[sim]\npolicy = "/etc/passwd"\n'),
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
    "far_depot.json": _json(
        {"frame": FRAME, "depots": [{**DEPOT, "x_m": -1e12}], "candidates": {"0": [0]}}
    ),
    "infinite_frame.json": _text(
        json.dumps({"frame": FRAME, "depots": [DEPOT], "candidates": {"0": [0]}}).replace(
            '"size_km": 10.0', '"size_km": Infinity'
        )
    ),
    "huge_history.json": _json(
        {"frame": FRAME, "depots": [{**DEPOT, "n_history": 1e300}], "candidates": {"0": [0]}}
    ),
    "other_city.json": _json(
        {
            "frame": {**FRAME, "center_lng": 116.40, "center_lat": 39.90},
            "depots": [{**DEPOT, "lng": 116.40, "lat": 39.90}],
            "candidates": {"0": [0]},
        }
    ),
    "moved_in_degrees.json": _json(
        {"frame": FRAME, "depots": [{**DEPOT, "lat": 31.23}], "candidates": {"0": [0]}}
    ),
    "deep.json": _text("[" * 100_000 + "]" * 100_000),
    "huge_int.json": _text(
        json.dumps({"frame": FRAME, "depots": [DEPOT], "candidates": {"0": [0]}}).replace(
            '"n_history": 3', '"n_history": ' + "1" * 5000
        )
    ),
    "frame_list.json": _json({"frame": [1, 2], "depots": [DEPOT], "candidates": {"0": [0]}}),
    "duplicate_id.json": _json(
        {
            "frame": FRAME,
            "depots": [DEPOT, {**DEPOT, "x_m": 500.0}],
            "candidates": {"0": [0, 1], "1": [1, 0]},
        }
    ),
    "depots_pipe.json": _pipe,
    "text_position.json": _json(
        {"frame": FRAME, "depots": [{**DEPOT, "x_m": "12"}], "candidates": {"0": [0]}}
    ),
    # Two frames, the first another city's: JSON keeps the last unsaid, marops refuses.
    "two_frames.json": _text(
        '{"frame": {"center_lng": 116.4}, '
        + json.dumps({"frame": FRAME, "depots": [DEPOT], "candidates": {"0": [0]}})[1:]
    ),
}


def _writes_on_load(p: Path) -> None:
    """A TorchScript actor whose loading creates ``planted.pth`` beside it (its
    ``__setstate__`` maps a file with ``torch.from_file(..., shared=True)``)."""
    import torch

    class WritesOnLoad(torch.nn.Module):
        def __init__(self, target: str) -> None:
            super().__init__()
            self.target = target

        def forward(self, obs: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
            return obs[:, :5], h

        @torch.jit.export
        def __getstate__(self) -> tuple[str, bool]:
            return (self.target, self.training)

        @torch.jit.export
        def __setstate__(self, state: tuple[str, bool]) -> None:
            self.target = state[0]
            planted = torch.from_file(self.target, shared=True, size=16)
            self.training = state[1] and planted.numel() > 0

    module = torch.jit.script(WritesOnLoad(str(p.parent / "planted.pth")))
    torch.jit.save(module, str(p))


class _System:
    """Unpickling runs ``touch planted.pth`` beside the file."""

    def __init__(self, target: Path) -> None:
        self.target = target

    def __reduce__(self) -> tuple[Callable[[str], int], tuple[str]]:
        import os

        return (os.system, (f"touch '{self.target}'",))


def _landing_weights(value: float) -> Callable[[Path], None]:
    """A landing actor's 16 weights, each ``value``."""

    def write(p: Path) -> None:
        import numpy as np
        from safetensors.numpy import save_file

        save_file({"weight": np.full(16, value, np.float32)}, str(p))

    return write


SIDE = {"obs_version": 3, "n_actions": 4, "hidden_size": 64}
LANDING = {"format": "marops-landing-actor/2", "operating_model": "paper"}
POLICY: dict[str, Callable[[Path], None]] = {
    "no_sidecar.pt": _bytes(b"PK\x03\x04not torchscript"),
    "not_torchscript.pt": _bytes(b"PK\x03\x04not torchscript"),
    "bad_sidecar_json.pt": _bytes(b"x"),
    "sidecar_lacks_field.pt": _bytes(b"x"),
    "sidecar_text_version.pt": _bytes(b"x"),
    "sidecar_old_version.pt": _bytes(b"x"),
    # Hostile actors (docs/method.md §6): refused before anything runs.
    "evil_on_load.pt": _writes_on_load,
    "evil_on_load_alone.pt": _writes_on_load,
    "evil_pickle.pt": lambda p: p.write_bytes(pickle.dumps(_System(p.parent / "planted.pth"))),
    "deep_sidecar.pt": _bytes(b"x"),
    "sidecar_model_list.pt": _bytes(b"x"),
    "folder.pt": lambda p: p.mkdir(),
    "folder.safetensors": lambda p: p.mkdir(),
    # Landing actors: finite float32 weights whose scores overflow; a sidecar whose
    # operating model is 10 MB of text (quoted in the refusal, it must stay short).
    "huge_weights.safetensors": _landing_weights(3.4e38),
    "model_10mb.safetensors": _landing_weights(0.5),
}
SIDECARS: dict[str, Callable[[Path], None]] = {
    "not_torchscript.json": _json(SIDE),
    "bad_sidecar_json.json": _text("{"),
    "sidecar_lacks_field.json": _json({"obs_version": 3, "n_actions": 4}),
    "sidecar_text_version.json": _json({**SIDE, "obs_version": "three"}),
    "sidecar_old_version.json": _json({**SIDE, "obs_version": 1}),
    "evil_on_load.json": _json(SIDE),
    "evil_pickle.json": _json(SIDE),
    "sidecar_model_list.json": _json({**SIDE, "operating_model": ["paper"]}),
    "deep_sidecar.json": _text("{" + '"a":{' * 50_000 + "}" * 50_001),
    "huge_weights.json": _json(LANDING),
    "model_10mb.json": _json({**LANDING, "operating_model": "x" * 10_000_000}),
}
FLEET: dict[str, Callable[[Path], None]] = {
    "fleet_not_json.json": _text("[1, 2"),
    "fleet_unknown_depot.json": _json([0, 99]),
    "fleet_negative.json": _json([-1]),
    "fleet_words.json": _json(["north"]),
    "fleet_empty.json": _json([]),
    "fleet_inf_battery.json": _json(
        {"types": {"big": {"battery_j": float("inf")}}, "counts": {"big": 2}}
    ),
    "fleet_inf_battery.toml": _text("[types.big]\nbattery_j = inf\n\n[counts]\nbig = 2\n"),
    "fleet_slow.json": _json({"types": {"slow": {"speed_ms": 0.0}}, "counts": {"slow": 1}}),
    "fleet_100000.json": _json({"counts": {"default": 100_000}}),
    "fleet_inf_count.json": _json({"counts": {"default": float("inf")}}),
    "fleet_too_long.json": _json([0] * 1001),
    "fleet_deep.json": _text("[" * 100_000 + "]" * 100_000),
    "fleet_deep.toml": _text("x = " + "[" * 5000 + "]" * 5000 + "\n"),
    "fleet_huge_int.toml": _text("[counts]\ndefault = " + "1" * 5000 + "\n"),
    "fleet_bool_battery.json": _json({"types": {"a": {"battery_j": True}}, "counts": {"a": 2}}),
    "fleet_drone_colour.json": _json({"drones": [{"depot": 1, "color": "red"}]}),
    "fleet_twice.json": _text('{"counts": {"default": 2}, "counts": {"default": 900}}'),
    "fleet_pipe.json": _pipe,
}
# What the one line names besides the file: the key, row or column at fault (any of a
# tuple: with a depots file, scattered data lie outside its study area).
NEEDLES: dict[str, str | tuple[str, ...]] = {
    "policy_unknown.toml": "invalid setting sim.policy: unknown policy '/etc/passwd'",
    "world_scattered.csv": ("column 'lng'", "holds none of the requests of world_scattered.csv"),
    "bool_lng.parquet": "column 'lng'",
    "lng_twice.csv": "row 1, column 'lng'",
    "all_nan_lng.csv": "none of its 20 rows can be used (20 bad coordinates)",
    "latin1_aoi.csv": "row 5, column 'aoi_id'",
    "dict_weight_text.parquet": "row 9, column 'weight_kg': expected a positive weight in kg",
    "header_no_line_end.csv": "row 2: the file has a header but no data rows",
    "header_field_200k.csv": "row 1: expected column names on the first line",
    "order_id_lists.parquet": "column 'order_id': expected a column of text",
    "lng_beyond_2_53.parquet": "column 'lng': expected coordinates in decimal degrees",
    "pipe.csv": "is not a regular file",
    "alpha_1e-300.toml": "plan.alpha",
    "rotor_1e-300.toml": "energy.rotor_diameter_m",
    "tz_too_long.toml": "data.tz",
    "pipe.toml": "gave nothing to read",
    "depots_pipe.json": "gave nothing to read",
    "fleet_pipe.json": "gave nothing to read",
    "payload_inf.toml": "energy.max_payload_kg",
    "window_1e-9.toml": "data.window_min",
    "battery_inf.toml": "energy.battery_j",
    "speed_inf.toml": "energy.speed_ms",
    "weight_sigma_inf.toml": "data.weight_sigma",
    "cda_inf.toml": "energy.cda_m2",
    "alpha_nan.toml": "plan.alpha",
    "speed_supersonic.toml": "energy.speed_ms",
    "speed_subnormal.toml": "energy.speed_ms",
    "efficiency_subnormal.toml": "energy.efficiency",
    "drones_100000.toml": "sim.drones",
    "bound_labels_10.toml": "plan.bound_labels",
    "center_off_earth.toml": "data.center",
    "far_depot.json": "depots[0].x_m",
    "infinite_frame.json": "frame",
    "other_city.json": "frame",
    "moved_in_degrees.json": "depots[0].lng",
    "fleet_inf_battery.json": "types.big.battery_j",
    "fleet_inf_battery.toml": "types.big.battery_j",
    "fleet_slow.json": "types.slow.speed_ms",
    "fleet_100000.json": "counts.default",
    "fleet_inf_count.json": "counts.default",
    "fleet_too_long.json": "'drones'",
    "evil_on_load.pt": "--trust-actor",
    "sidecar_model_list.pt": "key 'operating_model'",
    "folder.pt": "is a folder, expected a",
    "folder.safetensors": "is a folder, expected a",
    "huge_weights.safetensors": "column 'weight': holds a weight of magnitude 3.4e+38",
    "model_10mb.safetensors": "trained for the operating model 'xxx",
    "evil_on_load_alone.pt": "not found",
    "deep.toml": "nested too deeply",
    "huge_int.toml": "digits",
    "deep.json": "nested too deeply",
    "huge_int.json": "digits",
    "frame_list.json": "not a marops depots file",
    "duplicate_id.json": "depots[].id",
    "text_position.json": "depots[0].x_m",
    "deep_sidecar.pt": "nested too deeply",
    "fleet_deep.json": "nested too deeply",
    "fleet_deep.toml": "nested too deeply",
    "fleet_huge_int.toml": "digits",
    "bool_drones.toml": "key 'sim.drones'",
    "text_year.toml": "key 'data.year'",
    "number_bound.toml": "key 'plan.bound'",
    "stage_array.toml": "key 'plan': expected a table [plan]",
    "center_text.toml": "key 'data.center'",
    "center_bools.toml": "key 'data.center'",
    "fleet_bool_battery.json": "types.a.battery_j",
    "fleet_drone_colour.json": "drones[0].color",
    "fleet_twice.json": "the key 'counts' appears twice",
    "two_frames.json": "the key 'frame' appears twice",
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

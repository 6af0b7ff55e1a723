"""Same results before and after a change: fingerprints of route files, metrics and weights.

Runs the project's commands on small fixed inputs and reduces every output to a
fingerprint: the README example, two days of three ``marops synth`` cities for every
method, a mixed fleet, a hub city, ``marops evaluate``'s results.parquet and a
20-episode ``marops train`` (the actor's weights and its sidecar). A fingerprint covers
each file's whole content except what varies from run to run (wall times, the time a
file was written, the package version): see docs/decisions.md, "Same results".

    python benchmarks/same_results.py --check [FILE] [--only NAME...] [--keep DIR]
    python benchmarks/same_results.py --record FILE [--only NAME...]
    python benchmarks/same_results.py --smoke --check

``--check`` (default file tests/golden/same_results.json) prints one line per case and
exits 1 if any differs. NAME is a case name, a prefix of one or a glob (``synth-river-*``);
``--list`` prints the names. The commands run as ``marops`` from PATH, one process at a
time with one worker, in a temporary folder (depots cache included).
"""

from __future__ import annotations

import argparse
import fnmatch
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_FILE = ROOT / "tests" / "golden" / "same_results.json"
EXAMPLE = ROOT / "examples" / "shanghai_synth.csv"
FLEET = ROOT / "examples" / "fleet.toml"
PAPER_OPS = ROOT / "examples" / "paper-ops.toml"
"""The paper's operating model: the cases recorded before the realistic model became the
default fly it, so their fingerprints still hold (docs/decisions.md, "Same results")."""

METHODS = ("marops", "ops-global", "ops-random", "greedy", "squares", "mappo", "stay", "myopic")
# City shape -> synth seed; 600 orders a day over 3 days, the first two replayed (the
# third is the history the depots are segmented on).
SHAPES = {"hubs": 1, "river": 2, "corridor": 3}
OPS_METHODS = ("marops", "ops-global", "backlog", "rebalance")  # under the realistic model
SYNTH_ORDERS = "600"
SYNTH_DAYS = "3"
REPLAY_DAYS = "0801..0802"
SMOKE = ("example", "synth-river-greedy", "fleet")

# What varies from run to run with the same inputs and seed, so no fingerprint holds it.
# JSON keys, at any depth (metrics.json, hubs.json, the actor's sidecar, Parquet metadata):
VOLATILE_KEYS = frozenset({"created", "runtime_s", "solve_s", "training_time_s", "version"})
# Keys by path: the actor sidecar's package version, and the SHA-256 of the hubs file a
# hub replay read (kept out from when that file held its own `created`; its content is
# fingerprinted).
VOLATILE_PATHS = frozenset({"marops", "meta.hubs_file.sha256"})
# Columns (evaluate's results.parquet): wall times.
VOLATILE_COLUMNS = frozenset({"runtime_s", "solver_solve_s"})
PART_HEX = 12  # characters of a part's hash kept; the file's own hash is whole
JOURNAL = ".marops-files.json"  # a folder's record of marops' files (docs/outputs.md)


# ---------------------------------------------------------------- canonical forms


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _dumps(obj: Any) -> bytes:
    # Key order is kept: a reordered file is a changed file.
    return json.dumps(obj, ensure_ascii=False, allow_nan=True).encode()


def strip_volatile(obj: Any, path: str = "") -> Any:
    """The JSON value without the run-to-run varying keys."""
    if isinstance(obj, dict):
        kept = {}
        for k, v in obj.items():
            sub = f"{path}.{k}" if path else k
            if k not in VOLATILE_KEYS and sub not in VOLATILE_PATHS:
                kept[k] = strip_volatile(v, sub)
        return kept
    if isinstance(obj, list):
        return [strip_volatile(v, path) for v in obj]
    return obj


def _json_parts(obj: Any, path: str, depth: int, out: dict[str, str]) -> None:
    if depth and isinstance(obj, dict) and obj:
        for k, v in obj.items():
            _json_parts(v, f"{path}.{k}" if path else str(k), depth - 1, out)
    elif isinstance(obj, list) and obj and all(isinstance(v, dict) for v in obj):
        for i, v in enumerate(obj):  # records (days, hubs, evaluations): one part each key
            _json_parts(v, f"{path}[{i}]", depth, out)
    else:
        out[path or "."] = _sha(_dumps(obj))[:PART_HEX]


def json_fingerprint(obj: Any) -> dict[str, Any]:
    """sha256 of the JSON value and of its parts two keys deep (to say which key differs)."""
    parts: dict[str, str] = {}
    _json_parts(obj, "", 2, parts)
    return {"sha256": _sha(_dumps(obj)), "parts": parts}


def parquet_fingerprint(path: Path) -> dict[str, Any]:
    """sha256 of a Parquet file's schema, metadata (less volatile keys) and every value."""
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    table = table.drop_columns([c for c in table.column_names if c in VOLATILE_COLUMNS])
    meta = {
        k.decode(): strip_volatile(json.loads(v)) if k == b"marops" else v.decode()
        for k, v in (table.schema.metadata or {}).items()
    }
    parts = {
        "schema": _sha("\n".join(str(f) for f in table.schema).encode()),
        "metadata": _sha(_dumps(meta)),
        "rows": _sha(str(table.num_rows).encode()),
    }
    for name in table.column_names:
        # repr of Python values is exact (floats round-trip), whatever the chunking.
        parts[f"column {name}"] = _sha(repr(table.column(name).to_pylist()).encode())
    whole = _sha(_dumps(parts))
    return {"sha256": whole, "parts": {k: v[:PART_HEX] for k, v in parts.items()}}


def actor_fingerprint(path: Path) -> dict[str, Any]:
    """sha256 of a TorchScript actor's parameters: names, dtypes, shapes and values.

    Not the file's bytes: the archive holds a random serialization id and writes the
    modules' constants in hash-seed order.
    """
    import torch

    state = torch.jit.load(str(path), map_location="cpu").state_dict()
    parts = {}
    for name, tensor in sorted(state.items()):
        t = tensor.detach().cpu().contiguous()
        head = f"{name} {t.dtype} {tuple(t.shape)}\n".encode()
        parts[f"tensor {name}"] = _sha(head + t.numpy().tobytes())
    whole = _sha(_dumps(parts))
    return {"sha256": whole, "parts": {k: v[:PART_HEX] for k, v in parts.items()}}


def file_fingerprint(path: Path) -> dict[str, Any]:
    """The fingerprint of one output file, by its kind."""
    if path.suffix == ".parquet":
        return parquet_fingerprint(path)
    if path.suffix == ".pt":
        return actor_fingerprint(path)
    if path.suffix == ".json":
        return json_fingerprint(strip_volatile(json.loads(path.read_text(encoding="utf-8"))))
    if path.suffix == ".safetensors":  # a landing actor's weights: its bytes
        return {"sha256": _sha(path.read_bytes())}
    raise ValueError(f"no fingerprint for {path.name}")


def tree_fingerprints(folder: Path, patterns: tuple[str, ...]) -> dict[str, Any]:
    """Fingerprints of the files under ``folder`` matching any pattern, by relative path.
    A folder's journal (``.marops-files.json``, docs/outputs.md) counts without its
    entries for JSON documents, whose hashes change with the run's time their ``meta``
    holds (their content is fingerprinted without it), and not at all with none left."""
    found = sorted({p for pat in patterns for p in folder.glob(pat) if p.is_file()})
    out = {}
    for p in found:
        if p.name == JOURNAL:
            doc = json.loads(p.read_text(encoding="utf-8"))
            doc["files"] = {k: v for k, v in doc["files"].items() if not k.endswith(".json")}
            if doc["files"]:
                out[str(p.relative_to(folder))] = json_fingerprint(strip_volatile(doc))
        else:
            out[str(p.relative_to(folder))] = file_fingerprint(p)
    return out


# ---------------------------------------------------------------- running the commands


@dataclass
class Runner:
    """Runs ``marops`` commands in one work folder with a clean environment."""

    work: Path
    marops: str
    env: dict[str, str] = field(default_factory=dict)
    made: set[str] = field(default_factory=set)
    paper: bool = True
    """Fly the paper's operating model (``--config examples/paper-ops.toml``)."""

    @classmethod
    def create(cls, work: Path) -> Runner:
        exe = shutil.which("marops")
        if exe is None:
            sys.exit("marops is not on PATH: activate the project's virtual environment")
        # Nothing from the caller's MAROPS_* settings reaches the runs; the depots
        # cache lives (and dies) with the work folder.
        env = {k: v for k, v in os.environ.items() if not k.startswith("MAROPS_")}
        work = work.resolve()  # a relative XDG_DATA_HOME is ignored (the XDG rule)
        env["MAROPS_CACHE_DIR"] = str(work / "cache")
        env["XDG_DATA_HOME"] = str(work / "data")  # the record of trained actors stays here
        return cls(work=work, marops=exe, env=env)

    def __call__(self, *args: str) -> None:
        cmd = [self.marops, *args]
        if self.paper and args[0] != "synth" and "--config" not in args:
            # Copied into the work folder and named relatively: a trained actor's sidecar
            # records its command, which must not depend on where the checkout lies.
            shutil.copyfile(PAPER_OPS, self.work / PAPER_OPS.name)
            cmd += ["--config", PAPER_OPS.name]
        proc = subprocess.run(
            cmd, cwd=self.work, env=self.env, capture_output=True, text=True, check=False
        )
        if proc.returncode != 0:
            raise RuntimeError(
                f"marops {' '.join(args)} exited {proc.returncode}:\n{proc.stderr[-3000:]}"
            )

    def synth(self, shape: str) -> str:
        """The synth file of a city shape, made once per run (relative to the work folder)."""
        name = f"synth-{shape}.csv"
        if name not in self.made:
            (self.work / name).unlink(missing_ok=True)  # from an earlier run in a kept folder
            self(
                "synth",
                "--out",
                name,
                "--days",
                SYNTH_DAYS,
                "--seed",
                str(SHAPES[shape]),
                "--orders-per-day",
                SYNTH_ORDERS,
                "--shape",
                shape,
            )
            self.made.add(name)
        return name


ROUTE_FILES = ("**/*.parquet", "**/*.json")


def case_example(run: Runner, out: str) -> dict[str, Any]:
    run("replay-day", str(EXAMPLE), "--area", "square", "--date", "0811", "--method", "marops",
        "--out", out)  # fmt: skip
    return tree_fingerprints(run.work / out, ROUTE_FILES)


def case_synth(shape: str, method: str) -> Callable[[Runner, str], dict[str, Any]]:
    def case(run: Runner, out: str) -> dict[str, Any]:
        data = run.synth(shape)
        run(
            "replay-day",
            data,
            "--area",
            "square",
            "--dates",
            REPLAY_DAYS,
            "--method",
            method,
            "--out",
            out,
            "--workers",
            "1",
        )
        return tree_fingerprints(run.work / out, ROUTE_FILES)

    return case


def case_fleet(run: Runner, out: str) -> dict[str, Any]:
    run("replay-day", str(EXAMPLE), "--date", "0811", "--fleet", str(FLEET), "--out", out)
    return tree_fingerprints(run.work / out, ROUTE_FILES)


def case_hubs(run: Runner, out: str) -> dict[str, Any]:
    data = "synth-polycentric.csv"
    (run.work / data).unlink(missing_ok=True)
    run(
        "synth",
        "--out",
        data,
        "--days",
        "3",
        "--seed",
        "4",
        "--orders-per-day",
        "1200",
        "--shape",
        "polycentric",
    )
    run("segment", data, "--hubs", "auto", "--out", f"{out}/hubs.json")
    run(
        "replay-day",
        data,
        "--hubs",
        f"{out}/hubs.json",
        "--dates",
        "0802..0803",
        "--out",
        f"{out}/replay",
        "--workers",
        "1",
    )
    return tree_fingerprints(run.work / out, ROUTE_FILES)


def case_evaluate(run: Runner, out: str) -> dict[str, Any]:
    data = run.synth("river")
    run(
        "evaluate",
        data,
        "--area",
        "square",
        "--out",
        out,
        "--methods",
        "marops,greedy",
        "--dates",
        "0802..0803",
        "--workers",
        "1",
        "--no-plot",
        "--seed",
        "0",
    )
    return tree_fingerprints(run.work / out, ("results.parquet",))


def _train(run: Runner, out: str, actor: str, episodes: str, *first: str) -> dict[str, Any]:
    """Train ``actor`` (``first``: the options before ``--out``) for ``episodes`` on two
    days of the hubs city; the fingerprints of the actor and its sidecar."""
    data = run.synth("hubs")
    run("train", data, *first, "--out", f"{out}/{actor}", "--episodes", episodes,
        "--workers", "1", "--seed", "0", "--dates", "0801..0802", "--eval-days", "1",
        "--no-resume")  # fmt: skip
    return tree_fingerprints(run.work / out, (actor, str(Path(actor).with_suffix(".json"))))


def case_train(run: Runner, out: str) -> dict[str, Any]:
    return _train(run, out, "actor.pt", "20")


def case_train_es(run: Runner, out: str) -> dict[str, Any]:
    return _train(run, out, "land.safetensors", "60", "--algorithm", "es")


def realistic(case: Callable[[Runner, str], dict[str, Any]]) -> Callable[[Runner, str], Any]:
    """``case`` under the default (realistic) operating model."""

    def flown(run: Runner, out: str) -> dict[str, Any]:
        run.paper = False
        try:
            return case(run, out)
        finally:
            run.paper = True

    return flown


def all_cases() -> dict[str, Callable[[Runner, str], dict[str, Any]]]:
    """Every case by name, in the order they run: the paper's operating model, then the
    default (realistic) one, ``ops-*``."""
    cases: dict[str, Callable[[Runner, str], dict[str, Any]]] = {"example": case_example}
    for shape in SHAPES:
        for method in METHODS:
            cases[f"synth-{shape}-{method}"] = case_synth(shape, method)
    cases.update(fleet=case_fleet, hubs=case_hubs, evaluate=case_evaluate, train=case_train)
    cases["ops-example"] = realistic(case_example)
    for method in OPS_METHODS:
        cases[f"ops-synth-river-{method}"] = realistic(case_synth("river", method))
    cases["ops-train"] = realistic(case_train_es)
    return cases


def select(names: list[str], patterns: list[str] | None) -> list[str]:
    """Case names matching any pattern (a name, a prefix or a glob); all without patterns."""
    if not patterns:
        return names
    chosen = [n for n in names if any(fnmatch.fnmatch(n, p) or n.startswith(p) for p in patterns)]
    unknown = [
        p for p in patterns if not any(fnmatch.fnmatch(n, p) or n.startswith(p) for n in names)
    ]
    if unknown:
        sys.exit(f"no case matches {', '.join(unknown)}; cases: {', '.join(names)}")
    return chosen


def run_cases(
    names: list[str], keep: Path | None
) -> Iterator[tuple[str, dict[str, Any] | str, float]]:
    """Run the cases one by one: (name, fingerprints by file or why it failed, seconds)."""
    cases = all_cases()
    with tempfile.TemporaryDirectory(prefix="marops-same-") as tmp:
        work = Path(tmp)
        if keep is not None:
            keep.mkdir(parents=True, exist_ok=True)
            work = keep
        run = Runner.create(work)
        for name in names:
            out = work / name
            if out.exists():  # a kept folder from an earlier run
                shutil.rmtree(out)
            t0 = time.perf_counter()
            try:
                files: dict[str, Any] | str = cases[name](run, name)
            except RuntimeError as exc:  # a command failed: the case has no outputs
                files = str(exc)
            yield name, files, time.perf_counter() - t0


# ---------------------------------------------------------------- comparing


def differences(want: dict[str, Any], got: dict[str, Any]) -> list[str]:
    """What differs between two cases' fingerprints, file by file."""
    out = []
    for path in sorted(set(want) | set(got)):
        if path not in got:
            out.append(f"{path}: missing")
        elif path not in want:
            out.append(f"{path}: not in the recorded fingerprints")
        elif want[path]["sha256"] != got[path]["sha256"]:
            wp, gp = want[path].get("parts", {}), got[path].get("parts", {})  # binary files: none
            parts = [p for p in sorted(set(wp) | set(gp)) if wp.get(p) != gp.get(p)]
            shown = ", ".join(parts[:6]) + (f" (+{len(parts) - 6} more)" if len(parts) > 6 else "")
            out.append(f"{path}: {shown or 'content'}")
    return out


def write_record(path: Path, cases: dict[str, Any], update: bool) -> None:
    """Write the fingerprints (sorted keys); ``update`` keeps the file's other cases."""
    doc = {
        "about": "benchmarks/same_results.py fingerprints; see docs/decisions.md",
        "volatile": {
            "json_keys": sorted(VOLATILE_KEYS),
            "json_paths": sorted(VOLATILE_PATHS),
            "columns": sorted(VOLATILE_COLUMNS),
        },
        "cases": cases,
    }
    if update and path.exists():
        doc["cases"] = {**json.loads(path.read_text(encoding="utf-8"))["cases"], **cases}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n", encoding="utf-8")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--record", type=Path, metavar="FILE", help="write the fingerprints")
    mode.add_argument(
        "--check",
        type=Path,
        metavar="FILE",
        nargs="?",
        const=DEFAULT_FILE,
        help=f"compare with FILE [{DEFAULT_FILE.relative_to(ROOT)}]",
    )
    mode.add_argument("--list", action="store_true", help="print the case names")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="cases (names, prefixes, globs)")
    ap.add_argument("--smoke", action="store_true", help=f"only {', '.join(SMOKE)}")
    ap.add_argument("--keep", type=Path, metavar="DIR", help="run in DIR and keep the outputs")
    args = ap.parse_args()

    names = list(all_cases())
    if args.list:
        print("\n".join(names))
        return 0
    patterns = list(SMOKE) if args.smoke else args.only
    chosen = select(names, patterns)
    check = args.check or (DEFAULT_FILE if args.record is None else None)
    recorded: dict[str, Any] = {}
    if check is not None:
        recorded = json.loads(check.read_text(encoding="utf-8"))["cases"]

    t_start = time.perf_counter()
    got: dict[str, Any] = {}
    failed = 0
    for name, files, seconds in run_cases(chosen, args.keep):
        if isinstance(files, str):
            failed += 1
            print(f"{name:28s} FAILED: {files}", flush=True)
            continue
        got[name] = files
        if check is None:
            print(f"{name:28s} recorded ({len(files)} files, {seconds:.1f} s)", flush=True)
            continue
        if name not in recorded:
            failed += 1
            print(f"{name:28s} DIFFERENT: not recorded in {check}", flush=True)
            continue
        diff = differences(recorded[name], files)
        failed += bool(diff)
        verdict = "same" if not diff else "DIFFERENT: " + "; ".join(diff[:4])
        more = f" (+{len(diff) - 4} more files)" if len(diff) > 4 else ""
        print(f"{name:28s} {verdict}{more}  [{seconds:.1f} s]", flush=True)
    total = time.perf_counter() - t_start

    if args.record is not None:
        if failed:
            print(f"{failed} cases failed; {args.record} not written")
            return 1
        write_record(args.record, got, update=bool(patterns))
        print(f"wrote {args.record} ({len(got)} cases, {total:.0f} s)")
        return 0
    print(f"{len(chosen) - failed} of {len(chosen)} cases the same ({total:.0f} s)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

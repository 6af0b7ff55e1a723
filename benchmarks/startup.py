"""What each command imports, and what starting it costs: ``python -X importtime`` per
command, and whole-process wall times.

Commands: ``marops --help``, ``marops -V``, ``replay-day`` of the example's day 0811
under the realistic operating model (the default: method marops flies the landing
actor) with a depots file, and ``plan-window`` of its window 8. For each:

* the total of ``-X importtime``'s self times (every module the process imported) and
  the modules of largest cumulative import time (a module's cumulative time includes
  the modules it imported first; indentation shows who imported whom);
* which of the heavy libraries were imported, each with the self times of all its
  modules added up;
* whole-process wall time, min and median of ``--repeats`` runs (without
  ``-X importtime``, after one warm-up run).

An import-time budget is not a test (tests hold no timings; docs/decisions.md,
"Start-up and exit"): read the figures here, on a quiet machine.

    python benchmarks/startup.py [--repeats 5] [--top 8] [--only help V replay plan] [--smoke]

``--smoke``: every command once with ``-X importtime``, no timed repeats (CI runs it so
the script keeps up with the command line; its figures mean nothing).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).parent.resolve()]

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "shanghai_synth.csv"
MAIN = "from marops_cli.cli.app import main; main()"
"""``marops`` as its console script runs it, from this interpreter."""
HEAVY = (
    "torch",
    "numba",
    "scipy",
    "sklearn",
    "cvxpy",
    "highspy",
    "pandas",
    "pyarrow",
    "numpy",
    "pydantic",
    "matplotlib",
    "safetensors",
    "rich",
    "typer",
)
"""Libraries whose import a command may or may not need, largest first."""


OUT = "{out}"
"""Where a command's ``--out`` goes: a new folder each run (a replay keeps a day already
written with the same settings, so a second run into the same folder would do nothing)."""


def commands(tmp: Path) -> dict[str, list[str]]:
    depots = tmp / "depots.json"
    data = str(EXAMPLE)
    return {
        "--help": ["--help"],
        "-V": ["-V"],
        "replay-day (realistic, marops)": [
            "replay-day",
            data,
            "--date",
            "0811",
            "--depots",
            str(depots),
            "--method",
            "marops",
            "--out",
            OUT,
            "-q",
        ],
        "plan-window": [
            "plan-window",
            data,
            "--depots",
            str(depots),
            "--date",
            "0811",
            "--window",
            "8",
            "--out",
            OUT,
            "-q",
        ],
    }


_RUNS = iter(range(1 << 30))


def run(args: list[str], tmp: Path, importtime: bool = False) -> tuple[float, str]:
    """(wall s, stderr) of ``marops ARGS`` in a process of its own; :data:`OUT` in
    ``args`` is a new folder under ``tmp``."""
    out = str(tmp / f"out{next(_RUNS)}")
    args = [out if a == OUT else a for a in args]
    cmd = [sys.executable, *(["-X", "importtime"] if importtime else []), "-c", MAIN, *args]
    t = time.perf_counter()
    res = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    wall = time.perf_counter() - t
    err = res.stderr.decode(errors="replace")
    if res.returncode:
        raise SystemExit(f"failed ({res.returncode}): marops {' '.join(args)}\n{err[-2000:]}")
    return wall, err


def parse_importtime(err: str) -> list[tuple[str, int, int, int]]:
    """``(module, depth, self µs, cumulative µs)`` of each line ``-X importtime`` wrote,
    in its order (a module after the modules it imported)."""
    rows = []
    for line in err.splitlines():
        if not line.startswith("import time:") or "self [us]" in line:
            continue
        fields = line[len("import time:") :].split("|")
        self_us, cum_us, name = int(fields[0]), int(fields[1]), fields[2]
        depth = (len(name) - len(name.lstrip(" ")) - 1) // 2
        rows.append((name.strip(), depth, self_us, cum_us))
    return rows


def report(name: str, rows: list[tuple[str, int, int, int]], top: int) -> None:
    total = sum(r[2] for r in rows) / 1e6
    print(f"\nmarops {name}: {len(rows)} modules imported, {total:.3f} s of imports")
    print(f"  top {top} by cumulative import time:")
    for mod, depth, _, cum in sorted(rows, key=lambda r: -r[3])[:top]:
        print(f"    {cum / 1e6:7.3f} s  {'  ' * depth}{mod}")
    own: dict[str, int] = {}  # a library's modules' self times, all of them
    for mod, _, self_us, _ in rows:
        lib = mod.partition(".")[0]
        if lib in HEAVY:
            own[lib] = own.get(lib, 0) + self_us
    heavy = [f"{m} {own[m] / 1e6:.3f} s" for m in HEAVY if m in own]
    print(f"  heavy libraries (their own modules): {', '.join(heavy) if heavy else 'none'}")


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per command [5]")
    ap.add_argument("--top", type=int, default=8, help="modules listed per command [8]")
    ap.add_argument(
        "--only", nargs="+", help="commands whose name starts so, without dashes (help V replay)"
    )
    ap.add_argument("--smoke", action="store_true", help="every command once (CI)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="marops-startup-") as tmp_name:
        tmp = Path(tmp_name)
        segment = ["segment", str(EXAMPLE), "--dates", "0801..0810"]
        run([*segment, "--out", str(tmp / "depots.json"), "-q"], tmp)
        chosen = {
            k: v
            for k, v in commands(tmp).items()
            if not args.only or any(k.lstrip("-").startswith(o.lstrip("-")) for o in args.only)
        }
        walls: dict[str, list[float]] = {}
        for name, cmd in chosen.items():
            run(cmd, tmp)  # warm-up: page cache, compiled kernels' cache
            report(name, parse_importtime(run(cmd, tmp, importtime=True)[1]), args.top)
            if not args.smoke:
                walls[name] = [run(cmd, tmp)[0] for _ in range(args.repeats)]
    if walls:
        print(
            f"\nwhole process, {args.repeats} runs each after a warm-up "
            f"(load {os.getloadavg()[0]:.2f}, {os.cpu_count()} CPUs):"
        )
        print(f"  {'command':<32}  {'wall min':>8}  {'median':>6}")
        for name, w in walls.items():
            print(f"  {name:<32}  {min(w):8.3f}  {statistics.median(w):6.3f}")


if __name__ == "__main__":
    main()

"""kill -9 at random moments of `replay-day --dates` and `evaluate`; prints what was left.

After each kill: every output must be complete or absent (a day folder holds its three
files with metrics.json, or none), no worker may outlive the parent, and the next run
must remove the temporaries the killed one left and finish. Prints a line per kill and
the totals.

    python benchmarks/kills.py [--kills 10] [--seed 0] [--smoke]

``--smoke``: one early kill per command, of two-day runs (CI runs it so the script
keeps up with the command line).
"""

from __future__ import annotations

import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "shanghai_synth.csv"
CODE = "from marops_cli.cli.app import main; main()"


def commands(replay_dates: str, evaluate_dates: str, methods: str) -> dict[str, list[str]]:
    """The two runs that are stopped: a replay of ``replay_dates`` and an evaluation of
    ``methods`` over ``evaluate_dates``, both on the example's square."""
    area = [str(EXAMPLE), "--area", "square"]
    return {
        "replay-day": ["replay-day", *area, "--dates", replay_dates, "--method", "greedy"],
        "evaluate": ["evaluate", *area, "--methods", methods, "--dates", evaluate_dates]
        + ["--workers", "2", "--no-plot"],
    }


COMMANDS = commands("0801..0812", "0809..0812", "stay,greedy,ops-random")
SMOKE_COMMANDS = commands("0811..0812", "0811..0812", "stay,greedy")


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` or whose command line names our workers."""
    out = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            stat = (proc / "stat").read_text().split()
            cmd = (proc / "cmdline").read_bytes()
        except OSError:
            continue
        if int(stat[3]) == pid or (b"multiprocessing" in cmd and int(stat[3]) == 1):
            out.append(int(proc.name))
    return out


def _complete_or_absent(out: Path, command: str) -> bool:
    if command == "replay-day":
        for day in (p for p in out.iterdir() if p.is_dir()):
            names = {p.name for p in day.iterdir() if not p.name.endswith(".tmp")}
            if names not in ({"stops.parquet", "routes.parquet", "metrics.json"}, set()):
                return False
        return True
    final = {"results.parquet", "summary.csv", "summary.md"}
    names = {p.name for p in out.iterdir()} if out.exists() else set()
    return final <= names or not (final & names)


def one_kill(
    command: str, rng: random.Random, tmp: Path, i: int, smoke: bool = False
) -> dict[str, object]:
    out = tmp / f"{command}-{i}"
    cmd = (SMOKE_COMMANDS if smoke else COMMANDS)[command]
    args = [sys.executable, "-c", CODE, *cmd, "--out", str(out), "-q"]
    t0 = time.monotonic()
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(rng.uniform(1.0, 3.0) if smoke else rng.uniform(2.0, 9.0))
    finished = proc.poll() is not None
    if not finished:
        os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    time.sleep(0.5)
    orphans = len(_children(proc.pid))
    temps = len(list(out.rglob("*.tmp"))) if out.exists() else 0
    ok = _complete_or_absent(out, command) if out.exists() else True
    rerun = subprocess.run(args, capture_output=True, text=True)
    left = len(list(out.rglob("*.tmp")))
    return {
        "command": command,
        "killed_after_s": round(time.monotonic() - t0, 1),
        "finished_first": finished,
        "complete_or_absent": ok,
        "temporaries_left": temps,
        "orphan_workers": orphans,
        "rerun_rc": rerun.returncode,
        "temporaries_after_rerun": left,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kills", type=int, default=10, help="kills per command")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--smoke", action="store_true", help="1 early kill of a short run each (CI)")
    args = ap.parse_args()
    if args.smoke:
        args.kills = 1
    rng = random.Random(args.seed)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for command in COMMANDS:
            for i in range(args.kills):
                row = one_kill(command, rng, Path(tmp), i, args.smoke)
                rows.append(row)
                print(row, flush=True)
    for command in COMMANDS:
        mine = [r for r in rows if r["command"] == command]
        print(
            f"{command}: {len(mine)} kills, complete-or-absent "
            f"{sum(bool(r['complete_or_absent']) for r in mine)}/{len(mine)}, "
            f"left temporaries in {sum(int(r['temporaries_left']) > 0 for r in mine)}, "
            f"orphan workers {sum(int(r['orphan_workers']) for r in mine)}, "
            f"re-runs ok {sum(r['rerun_rc'] == 0 for r in mine)}/{len(mine)}, "
            f"temporaries after re-run {sum(int(r['temporaries_after_rerun']) for r in mine)}"
        )


if __name__ == "__main__":
    main()

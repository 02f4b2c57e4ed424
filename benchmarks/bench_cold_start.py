"""Benchmark: the cold start of `sgt generate` for one 5 s utterance, the whole command.

    python benchmarks/bench_cold_start.py [--runs 7] [--before REV]

Runs `python -m sgt_tui.cli generate one.sgt -o out.json` in a fresh process RUNS times (the
speech cache warmed by one run first, bytecode caches allowed as in an installed sgt) and prints
the median wall time and CPU time (user + sys: less sensitive to other load on a shared
machine), and which heavy modules the command imported. With ``--before REV`` (a git revision,
e.g. the commit before the fast start) it runs that revision's tree, exported to a temporary
folder, the same way, for a before/after comparison.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TEXT = "guide: Welcome to the mall! [pose:point_right] The shops are over there, and the food court is upstairs.\n"
HEAVY = ("torch", "scipy.signal", "onnxruntime", "soundfile", "librosa")
PROBE = ("import sys; import sgt_tui.cli as c; rc = c.main(sys.argv[1:]); "
         f"print('heavy:', ' '.join(m for m in {HEAVY!r} if m in sys.modules), file=sys.stderr); sys.exit(rc)")


def runs(tree: Path, work: Path, n: int, engine: str | None = None) -> tuple[list[float], list[float], str]:
    """Wall and CPU seconds of ``n`` cold `sgt generate` runs of the tree ``tree`` (``--engine
    engine`` when given), and the heavy modules the command imported."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(PYTHONPATH=str(tree), SGT_CACHE_DIR=str(work / "cache"))
    script = work / "one.sgt"
    script.write_text(TEXT)
    args = ["generate", str(script), "-o", str(work / "out.json")] + (["--engine", engine] if engine else [])
    cmd = [sys.executable, "-m", "sgt_tui.cli", *args]
    subprocess.run(cmd, cwd=tree, env=env, check=True, capture_output=True)  # speech cache and bytecode
    walls, cpus = [], []
    for _ in range(n):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t = time.perf_counter()
        subprocess.run(cmd, cwd=tree, env=env, check=True, capture_output=True)
        walls.append(time.perf_counter() - t)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    probe = subprocess.run([sys.executable, "-c", PROBE, *args],
                           cwd=tree, env=env, capture_output=True, text=True)
    heavy = next((line[len("heavy: "):] for line in probe.stderr.splitlines() if line.startswith("heavy:")), "?")
    return walls, cpus, heavy or "none"


def report(label: str, walls: list[float], cpus: list[float], heavy: str) -> None:
    print(f"{label}: median wall {statistics.median(walls):.2f} s (min {min(walls):.2f}), "
          f"median CPU {statistics.median(cpus):.2f} s, n={len(walls)}; heavy modules imported: {heavy}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--before", metavar="REV", help="also measure this git revision (before/after)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if args.before:
            old = tmp / "before"
            old.mkdir()
            archive = subprocess.run(["git", "archive", args.before], cwd=ROOT, capture_output=True, check=True).stdout
            subprocess.run(["tar", "-x", "-C", str(old)], input=archive, check=True)
            (tmp / "w0").mkdir()
            report(f"before ({args.before})", *runs(old, tmp / "w0", args.runs))
        (tmp / "w1").mkdir()
        report("now", *runs(ROOT, tmp / "w1", args.runs))
    print(f"(load average now: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: `sgt generate`'s neural engine with 1 and 2 torch threads, idle and under load.

    python benchmarks/bench_threads.py [--minutes 10] [--repeat 3] [--busy 0 1 2]

Generates a long script's motion (``--minutes`` of speech, estimated timing, so no speech
synthesis is timed) with the shipped weights, once per thread count and load, ``--repeat``
times, and prints the medians. The load is ``--busy`` background processes that each keep one
core busy (a Python loop), the way other jobs share a small machine. Each measurement runs
in a fresh process (torch's thread pool is per process).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, sys, time
sys.path.insert(0, {root!r})
from model.generate import generate
from model.neural import Options
generate({script!r}, engine="neural", timing="estimate", utterances=[0], options=Options(threads={threads}))  # warm
t = time.perf_counter()
take = generate({script!r}, engine="neural", timing="estimate", options=Options(threads={threads}))
print(json.dumps({{"seconds": time.perf_counter() - t, "frames": sum(c.n_frames for c in take.clips)}}))
"""

LINES = [
    "guide: Hello, and welcome to Riverside Mall! I can help you find anything you need today.",
    "visitor: Thank you. Where can I find the food court, and is the cinema open this late?",
    "guide: The food court is [pose:point_up] upstairs, and the cinema is over to the left.",
    "visitor: That is great. Do you know if they have [pose:shrug] anything for children?",
]


def _burn() -> None:
    while True:
        pass


def long_script(minutes: float) -> str:
    words = sum(len(line.split()) - 1 for line in LINES)
    repeats = max(1, round(minutes * 165 / words))  # 165 words a minute
    return "@seed 1\n" + "\n".join(LINES * repeats) + "\n"


def measure(script: Path, threads: int) -> dict:
    code = CHILD.format(root=str(ROOT), script=str(script), threads=threads)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "OMP_NUM_THREADS": str(threads)})
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--busy", type=int, nargs="+", default=[0, 1, 2], help="background busy processes (one per value)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "long.sgt"
        script.write_text(long_script(args.minutes))
        print(f"{os.cpu_count()} cores; load average {os.getloadavg()[0]:.1f} before starting")
        for busy in args.busy:
            burners = [multiprocessing.Process(target=_burn, daemon=True) for _ in range(busy)]
            for p in burners:
                p.start()
            try:
                for threads in args.threads:
                    runs = [measure(script, threads) for _ in range(args.repeat)]
                    secs = [r["seconds"] for r in runs]
                    print(f"busy processes {busy}, threads {threads}: median {statistics.median(secs):.2f} s "
                          f"(min {min(secs):.2f}, max {max(secs):.2f}) for {runs[0]['frames'] / 15 / 60:.1f} min of motion")
            finally:
                for p in burners:
                    p.terminate()
                    p.join()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

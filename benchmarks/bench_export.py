"""Benchmark of `sgt export`: seconds to write a 10-minute take for every rig and file type.

    python benchmarks/bench_export.py              # 10 minutes (9000 frames), 3 runs each
    python benchmarks/bench_export.py --minutes 2 --repeat 5

The take is library gestures one after another; each run retargets and writes the file to a
temporary folder (what `sgt export` does after loading the motion). Prints the median of the
runs per exporter. Target: seconds, not minutes.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numpy as np

from core.motion import MotionClip
from core.skeleton import FPS
from library import load_library
from renders.rig_export import write_rig_file

CASES = (("sgt", ".bvh"), ("sgt", ".glb"), ("vrm", ".glb"), ("mixamo", ".bvh"), ("mixamo", ".glb"),
         ("smplx", ".npz"), ("nao", ".json"), ("pepper", ".csv"))


def take(minutes: float) -> MotionClip:
    lib = load_library(use_config=False)
    names = lib.names()
    parts, n, i = [], 0, 0
    want = round(minutes * 60 * FPS)
    while n < want:
        p = lib.get(names[i % len(names)]).clip().poses
        parts.append(p)
        n += len(p)
        i += 1
    return MotionClip(poses=np.concatenate(parts)[:want])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    clip = take(args.minutes)
    print(f"take: {clip.n_frames} frames ({args.minutes:g} min at {FPS} fps), median of {args.repeat} runs")
    with tempfile.TemporaryDirectory() as tmp:
        for rig, suffix in CASES:
            times = []
            path = Path(tmp) / f"take{suffix}"
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                write_rig_file(path, clip, rig, suffix)
                times.append(time.perf_counter() - t0)
            size = path.stat().st_size / 1e6
            print(f"  --rig {rig:<7} {suffix:<6} median {statistics.median(times):6.2f} s   ({size:.1f} MB)")


if __name__ == "__main__":
    main()

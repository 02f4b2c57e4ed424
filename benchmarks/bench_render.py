"""Benchmark of `sgt render`: time for a 10 s clip at 320x320, and peak memory by clip length.

    python benchmarks/bench_render.py            # EGL and OSMesa, whichever start
    python benchmarks/bench_render.py --gl egl   # one platform
    python benchmarks/bench_render.py --repeat 5

Each measurement runs in a fresh Python process (peak RSS only ever grows), renders a
clip made of library gestures one after another with words and controls, and writes the
GIF to a temporary folder. Times include starting the renderer (GL context, meshes) and
writing the file; no model is run. Target: median <= 5 s for 10 s of motion; peak RSS
about the same for 5, 10 and 20 s clips (frames are streamed, not kept).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, resource, sys, tempfile, time
sys.path.insert(0, sys.argv[1])
import numpy as np
from library import load_library
from core.controls import Control
from core.motion import MotionClip
from core.words import TimedWord
from core.skeleton import FPS
seconds, repeat, size = float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
lib = load_library(use_config=False)
names = ["wave", "point_right", "open_arms", "shrug", "point_up", "clap", "beat_both", "stop"]
parts, n = [], 0
want = int(round(seconds * FPS))
while n < want:
    p = lib.get(names[len(parts) % len(names)]).clip().poses
    parts.append(p)
    n += len(p)
poses = np.concatenate(parts)[:want]
words = [TimedWord(f"w{i}", i * 0.4, i * 0.4 + 0.3) for i in range(int(seconds / 0.4))]
controls = [Control("pose" if i % 2 else "style", "w", i * 20, i * 20 + 12) for i in range(want // 20)]
clip = MotionClip(poses=poses, words=words, controls=controls)
from renders.animate import render_gif
times = []
with tempfile.TemporaryDirectory() as d:
    for r in range(repeat):
        t = time.perf_counter()
        info = render_gif(clip, f"{d}/bench.gif", size=(size, size))
        times.append(time.perf_counter() - t)
peak_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"times": times, "peak_mib": peak_kib / 1024, "frames": info["frames"],
                  "bytes": info["bytes"], "platform": info["platform"]}))
"""


def measure(gl: str, seconds: float, repeat: int, size: int) -> dict:
    env = dict(os.environ, SGT_GL=gl)
    env.pop("PYOPENGL_PLATFORM", None)
    r = subprocess.run([sys.executable, "-c", CHILD, str(ROOT), str(seconds), str(repeat), str(size)],
                       env=env, capture_output=True, text=True)
    if r.returncode != 0:
        return {"error": (r.stderr.strip().splitlines() or ["failed"])[-1]}
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--gl", choices=("egl", "osmesa", "both"), default="both")
    ap.add_argument("--repeat", type=int, default=3, help="timed renders of the 10 s clip (default 3)")
    ap.add_argument("--size", type=int, default=320)
    args = ap.parse_args()
    platforms = ("egl", "osmesa") if args.gl == "both" else (args.gl,)
    print(f"sgt render benchmark: {args.size}x{args.size}, {os.cpu_count()} CPUs visible")
    for gl in platforms:
        res = measure(gl, 10.0, args.repeat, args.size)
        if "error" in res:
            print(f"  {gl:7s} unavailable: {res['error']}")
            continue
        med = statistics.median(res["times"])
        verdict = "ok" if med <= 5.0 else "SLOW (target 5 s)"
        print(f"  {gl:7s} 10 s clip ({res['frames']} frames): median {med:.2f} s over {len(res['times'])} runs "
              f"({1000 * med / res['frames']:.1f} ms/frame; runs {', '.join(f'{t:.2f}' for t in res['times'])}) "
              f"-> {verdict}; GIF {res['bytes'] / 1024:.0f} KiB")
        peaks = []
        for seconds in (5.0, 10.0, 20.0):
            r = measure(gl, seconds, 1, args.size)
            if "error" in r:
                print(f"  {gl:7s} {seconds:4.0f} s clip: error {r['error']}")
                continue
            peaks.append(r["peak_mib"])
            print(f"  {gl:7s} {seconds:4.0f} s clip: peak RSS {r['peak_mib']:.0f} MiB "
                  f"(render {r['times'][0]:.2f} s)")
        if len(peaks) == 3:
            print(f"  {gl:7s} peak RSS growth 5 s -> 20 s: {peaks[2] - peaks[0]:+.1f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())

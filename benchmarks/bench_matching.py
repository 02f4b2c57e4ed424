"""Benchmark: the matching engine (model/matching.py) with the shipped database.

    python benchmarks/bench_matching.py [--repeat 21] [--runs 7]

Prints
1. the engine's time for 20 s of speech after loading, on one thread (BLAS and OpenMP limited
   to one before numpy loads): the search and joins (``match``) and the post-processing
   (``finish``: the 1-euro filter both ways, the speed correction, the pause hold, the blend);
   budget 50 ms (issue 26). The speech is a corpus-like utterance: espeak-ng-free, its features
   drawn so that words alternate with short pauses;
2. loading the database (a fresh process: reading and decompressing the file, the derived arrays);
3. a whole cold ``sgt generate --engine matching`` of one 5 s utterance (the speech cache warmed
   by one run first, as benchmarks/bench_cold_start.py does): median wall and CPU time; budget 0.6 s;
4. the database file's size (budget 200 MB).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
LOAD = "import time, sys; t = time.perf_counter(); from model import matching; matching.load(); print(time.perf_counter() - t)"


def speech(n: int, seed: int = 0):
    """(audio features, word ids, onsets, words) of ``n`` frames: words of 2-6 frames, gaps of 0-4."""
    import numpy as np

    from core.words import TimedWord
    from model.features import AUDIO_DIM, word_features

    rng = np.random.default_rng(seed)
    audio = np.full((n, AUDIO_DIM), -2.0, np.float32)
    words, t = [], 3
    while t < n - 8:
        d = int(rng.integers(2, 7))
        audio[t : t + d] = rng.uniform(0.0, 1.0, size=(d, AUDIO_DIM))
        words.append(TimedWord("word", t / 15, (t + d) / 15))
        t += d + int(rng.integers(0, 5))
    ids, onsets = word_features(words, n)
    return audio, ids, onsets, words


def engine_time(repeat: int) -> None:
    from core.controls import ControlArrays
    from model import matching

    db = matching.load()
    n = 20 * 15
    audio, ids, onsets, words = speech(n)
    arrays = ControlArrays.empty(n)
    arrays.pose[140:145] = db.poses[1000]
    arrays.pose_mask[140:145] = 1.0
    arrays.style[200:, 0], arrays.style_mask[200:, 0] = 1.0, 1.0
    for _ in range(3):
        matching.finish(matching.match(db, audio, ids, onsets, arrays, 0, 5), arrays, words=words)
    t_match, t_finish = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        raw = matching.match(db, audio, ids, onsets, arrays, 0, 5)
        t1 = time.perf_counter()
        matching.finish(raw, arrays, words=words)
        t2 = time.perf_counter()
        t_match.append(t1 - t0)
        t_finish.append(t2 - t1)
    total = [a + b for a, b in zip(t_match, t_finish)]
    print(f"20 s of speech, one thread ({repeat} runs): match {1000 * statistics.median(t_match):.1f} ms, "
          f"finish {1000 * statistics.median(t_finish):.1f} ms, total median {1000 * statistics.median(total):.1f} ms "
          f"(min {1000 * min(total):.1f} ms; budget 50 ms)")


def load_time(runs: int) -> None:
    times = [float(subprocess.run([sys.executable, "-c", LOAD], cwd=ROOT, check=True, capture_output=True,
                                  text=True).stdout) for _ in range(runs)]
    print(f"loading the database in a fresh process: median {1000 * statistics.median(times):.0f} ms")


def cold_generate(runs: int) -> None:
    from bench_cold_start import runs as cold_runs  # (benchmarks/ is on sys.path: this script's folder)

    with tempfile.TemporaryDirectory() as tmp:
        walls, cpus, heavy = cold_runs(ROOT, Path(tmp), runs, engine="matching")
    print(f"cold `sgt generate --engine matching` of one 5 s utterance ({runs} runs): wall median "
          f"{statistics.median(walls):.2f} s (min {min(walls):.2f}), CPU median {statistics.median(cpus):.2f} s, "
          f"heavy imports: {heavy}; budget 0.6 s")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeat", type=int, default=21)
    p.add_argument("--runs", type=int, default=7)
    args = p.parse_args()
    from model import matching

    size = matching.DEFAULT_DB.stat().st_size
    print(f"database {matching.DEFAULT_DB.relative_to(ROOT)}: {size / 2**20:.1f} MiB (budget 200 MB)")
    engine_time(args.repeat)
    load_time(args.runs)
    cold_generate(args.runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())

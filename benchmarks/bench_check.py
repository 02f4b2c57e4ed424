"""Benchmark: how long `sgt check` takes on a 10,000-line script (target: under 1 s).

    python benchmarks/bench_check.py [--lines 10000] [--repeat 5]

Builds a varied script from the shipped examples (utterances with pose, style and pause marks,
every line's words shuffled so no two lines are equal), then times:
- the front end in-process (parse + static checks + estimated timing + control arrays),
- the whole `sgt check FILE` command in a subprocess (interpreter start and imports included),
- `sgt --help`.
Prints the median and min of each. Figures vary with machine load: quote medians.
"""

from __future__ import annotations

import argparse
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def make_script(n_lines: int, seed: int = 0) -> str:
    rng = random.Random(seed)
    header, bodies = [], []
    for f in sorted((ROOT / "examples").glob("*.sgt")):
        for line in f.read_text(encoding="utf-8").splitlines():
            if line.startswith("@preset"):
                header.append(line)
            elif line and not line.startswith(("#", "@", " ")):
                bodies.append(line)
    vocab = "the a shelf river valley merchant apples today we look at how this that over there".split()
    out = list(dict.fromkeys(header))
    while len(out) < n_lines:
        line = rng.choice(bodies)
        extra = " ".join(rng.choice(vocab) for _ in range(rng.randint(2, 8)))
        out.append(f"{line} {extra}.")
    return "\n".join(out) + "\n"


def timeit(fn, repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return times


def report(label: str, times: list[float]) -> None:
    print(f"{label:<44} median {statistics.median(times) * 1000:8.1f} ms   min {min(times) * 1000:8.1f} ms   (n={len(times)})")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lines", type=int, default=10000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()

    from dsl.compiler import compile_file
    from library import load_library

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.sgt"
        path.write_text(make_script(args.lines), encoding="utf-8")
        lib = load_library(use_config=False)
        result = compile_file(path, timing="estimate", library=lib)
        n_err = sum(d.is_error for d in result.diagnostics)
        print(f"script: {args.lines} lines, {len(result.script.utterances)} utterances, {n_err} errors, "
              f"{sum(len(u.controls) for u in result.plan.utterances) if result.plan else 0} controls")
        report(f"front end in-process ({args.lines} lines)", timeit(lambda: compile_file(path, timing="estimate", library=lib), args.repeat))
        sgt = [sys.executable, "-m", "sgt_tui.cli"]
        report(f"`sgt check` subprocess ({args.lines} lines)", timeit(lambda: subprocess.run(sgt + ["check", "-q", str(path)], check=False, capture_output=True), args.repeat))
        report("`sgt --help` subprocess", timeit(lambda: subprocess.run(sgt + ["--help"], check=True, capture_output=True), args.repeat))
    return 0


if __name__ == "__main__":
    sys.exit(main())

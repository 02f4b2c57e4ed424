"""Benchmark: how long `sgt check` takes on a 10,000-line script (target: under 1 s), and on
600 pose marks whose strokes are all late (target: under 2 s).

    python benchmarks/bench_check.py [--lines 10000] [--repeat 5] [--late 600]

Builds a script from the shipped examples: each line one of their utterances (pose, style and
pause marks, escapes, speakers) followed by 2-8 random words, so that about 98% of the lines
are distinct (nothing in the front end caches by line, so repetition would not help it anyway).
Then times:
- the whole `sgt check FILE` command in a subprocess (interpreter start and imports included),
  warm (the usual case), and the same on the script with a mistake on every 10th line (error
  recovery and did-you-mean suggestions, ~700 diagnostics, the first 50 printed),
- cold: the same with an empty speech cache (`sgt check` does not use it: the overlap check
  runs on estimated timing, see docs/language.md) and with an empty Python bytecode cache
  (every module, numpy included, compiled again: the first run after an install),
- in-process: parse + static checks (`analyse`), and the whole front end `sgt check` runs
  (`compile_file` with estimated timing: + timing + pose placement and overlap checks),
  both with the garbage collector on as in any program and off as in `sgt check`,
- `sgt --help`,
- `sgt check` of one line of ``--late`` marks ``[pose:wave x3 hold=10s] hi``: each stroke is
  late behind the one before (a chain as long as the line), and each late stroke's warning
  carries a hint found by trying the earlier gesture changed (:func:`dsl.realize.hint`); the
  same marks one per line of one utterance (continuation lines: the source excerpts are short),
  and the front end alone in-process (with ``SGT_MAX_SECONDS`` raised: 600 holds of 10 s
  last longer than the hour a script may last by default).
Prints the median and min of each. Figures vary with machine load: quote medians.
"""

from __future__ import annotations

import argparse
import gc
import os
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


def with_errors(script: str, every: int = 10, seed: int = 0) -> str:
    """``script`` with a typical mistake on every ``every``-th line (from the 10th on)."""
    rng = random.Random(seed)
    mistakes = [
        lambda line: line.replace("[pose:", "[pose:x", 1),  # unknown gesture, with suggestions
        lambda line: line.replace("]", "", 1),  # unclosed tag: Lark and error recovery
        lambda line: line.replace("<", "<<", 1),
        lambda line: line + " [pose:wave x5]",  # unknown option
        lambda line: line.replace("speed", "sped", 1),
    ]
    lines = script.splitlines()
    for i in range(every, len(lines), every):
        lines[i] = rng.choice(mistakes)(lines[i])
    return "\n".join(lines) + "\n"


def late_strokes(n: int, per_line: bool = False) -> str:
    """``n`` marks of a waving hand held 10 s, one word apart: every stroke after the first is
    late (the hand still holds the one before), the chain as long as the marks."""
    marks = ["[pose:wave x3 hold=10s] hi"] * n
    return ("\n    ".join(marks) if per_line else " ".join(marks)) + "\n"


def timeit(fn, repeat: int, collect: bool = True) -> list[float]:
    times = []
    for _ in range(repeat):
        if not collect:
            gc.disable()
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
        del result
        gc.enable()
        gc.collect()
    return times


def report(label: str, times: list[float]) -> None:
    print(f"{label:<44} median {statistics.median(times) * 1000:8.1f} ms   min {min(times) * 1000:8.1f} ms   (n={len(times)})")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lines", type=int, default=10000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--late", type=int, default=600, help="late-stroke marks (default 600)")
    args = ap.parse_args()

    from dsl.compiler import compile_file
    from dsl.parser import analyse
    from library import load_library

    # A 10,000-line script speaks for about 16 hours, past the default limit on a performance's
    # length (SGT411, core/limits.py), where the analysis would stop at the first line past it:
    # raise the limit, so the whole script is checked, as a user who sets it would have it.
    os.environ["SGT_MAX_SECONDS"] = str(max(3600, 30 * args.lines))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.sgt"
        path.write_text(make_script(args.lines), encoding="utf-8")
        lib = load_library(use_config=False)
        result = compile_file(path, timing="estimate", library=lib)
        n_err = sum(d.is_error for d in result.diagnostics)
        print(f"script: {args.lines} lines, {len(result.script.utterances)} utterances, {n_err} errors, "
              f"{sum(len(u.controls) for u in result.plan.utterances) if result.plan else 0} controls")
        del result
        bad = Path(tmp) / "big_errors.sgt"
        bad.write_text(with_errors(path.read_text(encoding="utf-8")), encoding="utf-8")
        sgt = [sys.executable, "-m", "sgt_tui.cli"]
        report(f"`sgt check` subprocess ({args.lines} lines)", timeit(lambda: subprocess.run(sgt + ["check", "-q", str(path)], check=False, capture_output=True), args.repeat))
        report("  same, a mistake every 10th line", timeit(lambda: subprocess.run(sgt + ["check", str(bad)], check=False, capture_output=True), args.repeat))

        def cold(kind: str):
            fresh = Path(tempfile.mkdtemp(dir=tmp))
            env = dict(os.environ, SGT_CACHE_DIR=str(fresh)) if kind == "speech" else dict(os.environ, PYTHONPYCACHEPREFIX=str(fresh))
            return subprocess.run(sgt + ["check", "-q", str(path)], check=False, capture_output=True, env=env)

        report("  cold: empty speech cache", timeit(lambda: cold("speech"), args.repeat))
        report("  cold: empty bytecode cache", timeit(lambda: cold("bytecode"), args.repeat))
        source, names = path.read_text(encoding="utf-8"), lib.names()
        front_end = lambda: compile_file(path, timing="estimate", library=lib)  # noqa: E731
        parse = lambda: analyse(source, str(path), gesture_names=names)  # noqa: E731
        for collect in (True, False):
            gc_state = "gc on" if collect else "gc off"
            report(f"parse + analyse in-process ({gc_state})", timeit(parse, args.repeat, collect))
            report(f"front end in-process ({gc_state})", timeit(front_end, args.repeat, collect))
        report("`sgt --help` subprocess", timeit(lambda: subprocess.run(sgt + ["--help"], check=True, capture_output=True), args.repeat))
        # 600 holds of 10 s last 100 minutes: over the hour a script may last (core/limits.py),
        # which alone would be one error; a longer limit shows every warning, hints included
        os.environ["SGT_MAX_SECONDS"] = str(max(3600, 30 * args.lines, 20 * args.late))
        late = Path(tmp) / "late.sgt"
        late.write_text(late_strokes(args.late), encoding="utf-8")
        result = compile_file(late, timing="estimate", library=lib)
        print(f"late strokes: {args.late} marks, {sum(d.code == 'SGT401' for d in result.diagnostics)} late-stroke warnings")
        del result
        report(f"`sgt check` subprocess ({args.late} late strokes)", timeit(lambda: subprocess.run(sgt + ["check", str(late)], check=False, capture_output=True), args.repeat))
        lines = Path(tmp) / "late_lines.sgt"
        lines.write_text(late_strokes(args.late, per_line=True), encoding="utf-8")
        report("  same, one mark per line", timeit(lambda: subprocess.run(sgt + ["check", str(lines)], check=False, capture_output=True), args.repeat))
        report("  front end in-process", timeit(lambda: compile_file(late, timing="estimate", library=lib), args.repeat))
    print(f"load average (1, 5, 15 min) after the runs: {', '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} CPUs")
    return 0


if __name__ == "__main__":
    sys.exit(main())

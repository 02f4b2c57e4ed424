"""`sgt suggest` on a 500-line script, warm: the whole command in a fresh process (Python's start,
the script's analysis, the WordNet look-ups, writing the result), after one run that warms the
disk cache and the bytecode. Prints the median of the runs, and the median of the suggestions
alone (in-process, WordNet's first look-ups included).

    python benchmarks/bench_suggest.py [--lines 500] [--runs 7]

The lines are the labelled sentences of tests/data (five registers), two speakers taking turns.
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

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))


def script(lines: int) -> str:
    from suggest_eval import DEV, LABELS, TEST, read_labels

    sentences = [text for path in (TEST, DEV, LABELS) for text, _ in read_labels(path)]
    return "".join(f"{('guide', 'visitor')[n % 2]}: {sentences[n % len(sentences)]}\n" for n in range(lines))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lines", type=int, default=500)
    ap.add_argument("--runs", type=int, default=7)
    args = ap.parse_args()
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # an installed sgt keeps its bytecode (as bench_cold_start.py)
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "long.sgt"
        src.write_text(script(args.lines), encoding="utf-8")
        cmd = [sys.executable, "-m", "sgt_tui.cli", "suggest", str(src), "-o", str(Path(tmp) / "out.sgt")]
        subprocess.run(cmd, cwd=ROOT, env=env, check=True, capture_output=True)  # warm-up
        times = []
        for _ in range(args.runs):
            t = time.perf_counter()
            r = subprocess.run(cmd, cwd=ROOT, env=env, check=True, capture_output=True, text=True)
            times.append(time.perf_counter() - t)
        print(f"sgt suggest, {args.lines} lines, warm: median {statistics.median(times):.2f} s "
              f"(min {min(times):.2f}, max {max(times):.2f}, {args.runs} runs; {r.stderr.strip()})")

        from dsl.parser import analyse
        from dsl.suggest import suggest
        from library import load_library
        from library.lexicon import find_lexicon
        from library.words import load_word_rules

        parsed = analyse(src.read_text(encoding="utf-8"), str(src))
        lib, rules = load_library(use_config=False), load_word_rules()
        inner = []
        for _ in range(args.runs):
            t = time.perf_counter()
            suggest(parsed, lib, rules, find_lexicon())
            inner.append(time.perf_counter() - t)
        print(f"the suggestions alone (analysed script in hand): first {inner[0]:.3f} s, "
              f"median {statistics.median(inner):.3f} s; WordNet: {find_lexicon().folder if find_lexicon() else 'none'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

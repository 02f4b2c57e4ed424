"""How well `sgt suggest` chooses gestures from the words, on labelled sentences (the figures of
the README and docs/library.md).

    python scripts/suggest_check.py              # the test half of the fresh set: the figures
    python scripts/suggest_check.py --set dev    # the development half (the one rules are tuned on)
    python scripts/suggest_check.py --set val    # tests/data/suggest_val.txt, a second development set
    python scripts/suggest_check.py --set old    # tests/data/suggest_labels.txt, the first set (regression)
    python scripts/suggest_check.py --list       # and every miss, wrong and spurious suggestion
    python scripts/suggest_check.py --sweep      # the WordNet thresholds, measured on the development half
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from suggest_eval import DEV, LABELS, TEST, VAL, evaluate, read_labels, report

SETS = {"test": TEST, "dev": DEV, "val": VAL, "old": LABELS}


def sweep() -> None:
    """Each pair of thresholds (the text word's senses, the table word's senses) on the development half."""
    import dsl.suggest as s

    labels = read_labels(DEV)
    for text in (1, 2, 3, 5):
        for seed in (1, 2, 3, 5):
            s.TEXT_SENSES, s.SEED_SENSES = text, seed
            print(f"TEXT_SENSES={text} SEED_SENSES={seed}: {report(evaluate(labels))}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=sorted(SETS), default="test", help="which labelled sentences (default: test)")
    ap.add_argument("--list", action="store_true", help="list every mistake")
    ap.add_argument("--sweep", action="store_true", help="measure the WordNet thresholds on the development half")
    args = ap.parse_args()
    if args.sweep:
        sweep()
        return 0
    c = evaluate(read_labels(SETS[args.set]))
    print(f"{SETS[args.set].name}: {report(c)}")
    if args.list:
        print("\n".join(c["mistakes"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

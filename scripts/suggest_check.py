"""How well `sgt suggest` chooses gestures from the words, on the labelled sentences of
tests/data/suggest_labels.txt (the figures of the README and docs/library.md).

    python scripts/suggest_check.py            # the figures
    python scripts/suggest_check.py --list     # and every miss, wrong and spurious suggestion
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from suggest_eval import evaluate, report  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--list", action="store_true", help="list every mistake")
    args = ap.parse_args()
    c = evaluate()
    print(report(c))
    if args.list:
        print("\n".join(c["mistakes"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Fit the style normalisation statistics (model/style_stats.json).

    python scripts/fit_style_stats.py            # from the motion library (default)

Until the training corpus exists, the reference motion is the built-in motion library: every
gesture at 1x, 2x and 3x, plain and mirrored, strung together with rests in between, in a
fixed order. The statistics are means and standard deviations of the raw Eq. 4-6 values.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from library import load_library  # noqa: E402
from model.skeleton import REST_POSE  # noqa: E402
from model.style import STATS_PATH, fit_stats  # noqa: E402


def library_reference() -> list[np.ndarray]:
    lib = load_library(use_config=False)
    rest = np.repeat(REST_POSE[None], 8, axis=0)
    motions = []
    for g in lib:
        pieces = []
        for speed in (1, 2, 3):
            for flip in (False, True):
                pieces += [g.clip(speed=speed, flip=flip).poses, rest]
        motions.append(np.concatenate(pieces))
    return motions


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-o", "--output", default=str(STATS_PATH))
    args = ap.parse_args()
    stats = fit_stats(library_reference(), source="built-in motion library (scripts/fit_style_stats.py)")
    from model.controls import STYLE_NAMES
    from model.fileio import atomic_write_text

    atomic_write_text(Path(args.output), stats.to_json())
    for name, m, s in zip(STYLE_NAMES, stats.mean, stats.std):
        print(f"{name:<11} mean {m:8.4f}  std {s:8.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Fit the style normalisation statistics (model/style_stats.json).

    python scripts/fit_style_stats.py --corpus data/corpus   # the training split (shipped)
    python scripts/fit_style_stats.py                         # the motion library instead

As in SGToolkit, style values are normalised with the mean and standard deviation of the raw
Eq. 4-6 statistics on the training data: the train split of the procedural corpus
(``sgt corpus``). Without a corpus, the reference is the built-in motion library: every
gesture at 1x, 2x and 3x, plain and mirrored, strung together with rests in between.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from core.skeleton import REST_POSE  # noqa: E402
from library import load_library  # noqa: E402
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
    ap.add_argument("--corpus", help="fit on the train split of this corpus")
    args = ap.parse_args()
    if args.corpus:
        from model.training.corpus import load_corpus, load_manifest

        manifest = load_manifest(args.corpus)
        motions = [c["poses"] for c in load_corpus(args.corpus, "train")]
        source = f"train split of the procedural corpus (seed {manifest['seed']}, {manifest['total_hours']:.2f} h; scripts/fit_style_stats.py --corpus)"
        stats = fit_stats(motions, source=source)
    else:
        stats = fit_stats(library_reference(), source="built-in motion library (scripts/fit_style_stats.py)")
    from core.controls import STYLE_NAMES
    from core.fileio import atomic_write_text

    atomic_write_text(Path(args.output), stats.to_json())
    for name, m, s in zip(STYLE_NAMES, stats.mean, stats.std):
        print(f"{name:<11} mean {m:8.4f}  std {s:8.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

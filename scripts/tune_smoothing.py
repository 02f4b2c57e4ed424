"""Choose the 1-euro filter's settings on the validation split, by measurement.

    python scripts/tune_smoothing.py --weights runs/X/generator.pt [--corpus data/corpus]

Runs the network once per val clip (no controls, and style controls from the reference), then
applies the 1-euro filter with each (min_cutoff, beta) of a small grid, plus no smoothing and the
moving average, and prints for each: jerk relative to the reference (target within 25%), mean
wrist speed relative to the reference, the all-joint Hellinger distance of speed histograms and
SCS (style controls). The shipped default (model/postprocess.py) is the setting picked here.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from core.controls import ControlArrays  # noqa: E402
from model import neural, postprocess  # noqa: E402
from model.training import metrics  # noqa: E402
from model.training.corpus import load_corpus  # noqa: E402
from model.weights import load_weights  # noqa: E402

GRID = [(1.5, 0.3), (2.0, 0.3), (3.0, 0.3), (4.0, 0.5), (5.0, 0.5), (6.0, 0.5), (8.0, 0.5)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--weights", required=True)
    ap.add_argument("--corpus", default="data/corpus")
    ap.add_argument("--split", default="val")
    args = ap.parse_args()
    model, _ = load_weights(args.weights)
    clips = load_corpus(args.corpus, args.split)
    refs = [c["poses"] for c in clips]
    free, styled, sctl = [], [], []
    for i, c in enumerate(clips):
        sc = metrics.style_control(c["poses"])
        sctl.append(sc)
        free.append(neural.run_windows(model, c["audio"], c["word_ids"], c["onsets"], ControlArrays.empty(len(c["poses"])), i))
        styled.append(neural.run_windows(model, c["audio"], c["word_ids"], c["onsets"], sc, i))
    ref_stats = metrics.group_statistics(refs, "all")
    ref_wrist = metrics.group_statistics(refs, "wrists")
    print(f"{'smoothing':24} {'jerk/ref':>8} {'wrist spd/ref':>13} {'H all':>6} {'SCS':>6}")
    settings = [("none", lambda p: p), ("moving_average", postprocess.moving_average)]
    settings += [(f"one_euro {mc:g} Hz, beta {b:g}", lambda p, mc=mc, b=b: postprocess.one_euro(p, min_cutoff=mc, beta=b))
                 for mc, b in GRID]
    for name, f in settings:
        fr = [f(p) for p in free]
        st = [f(p) for p in styled]
        jr = metrics.group_statistics(fr, "all").jerk / ref_stats.jerk
        wr = metrics.group_statistics(fr, "wrists").speed / ref_wrist.speed
        h = metrics.speed_hellinger(refs, fr, "all")
        s = np.mean([metrics.scs(c.style, p, c.style_mask) for c, p in zip(sctl, st)])
        print(f"{name:24} {jr:8.3f} {wr:13.3f} {h:6.3f} {s:6.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

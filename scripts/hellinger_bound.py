"""How low can the all-joint Hellinger distance go without knowing each clip's style?

Issue 26 asks the generators for an all-joint Hellinger distance (per clip, of the joint-speed
histograms against the clip's reference, averaged: ``model/training/metrics.py``) of at most
0.13. The reference of every corpus clip is the teacher playing the clip's words in a style
(speed, space, handedness) drawn for that clip alone, independently of its voice, rate and
text (``model/training/corpus.py``): no input of a generator reveals it. ``sgt eval``'s
``rules`` row, the re-seeded teacher, is run *with* that style. This script runs the same
teacher on the same words, accents and side three ways:

- ``own style``: the clip's own drawn style (what the ``rules`` row gets);
- ``neutral style``: speed, space and handedness 0 (the style a generator that cannot see
  the clip's style would aim for on average);
- ``another clip's style``: the style of a clip drawn at random (a generator that plays some
  take's style, as the matching engine does);

and prints each one's Hellinger distance, averaged over the clips, as ``sgt eval`` computes it.
A generator given only the speech cannot be expected to beat the ``neutral`` row.

    python scripts/hellinger_bound.py --corpus data/heldout --seed 0
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from core.skeleton import mirror_pose
from core.words import TimedWord
from model.teacher import teach
from model.training import metrics
from model.training.corpus import load_corpus
from model.training.evaluate import RULES_SEED

NEUTRAL = {"speed": 0.0, "space": 0.0, "handedness": 0.0}


def distances(clips, seed: int) -> dict[str, float]:
    """Mean per-clip Hellinger distance of the re-seeded teacher under each style choice."""
    other = np.random.default_rng(1000 + seed).permutation(len(clips))
    choices = {
        "own style": lambda i, meta: meta.get("teacher_style") or meta.get("style"),
        "neutral style": lambda i, meta: NEUTRAL,
        "another clip's style": lambda i, meta: clips[other[i]]["meta"].get("teacher_style") or NEUTRAL,
    }
    out = {}
    for name, style_of in choices.items():
        hs = []
        for i, clip in enumerate(clips):
            meta = clip["meta"]
            poses = teach([TimedWord.from_dict(w) for w in meta["words"]], len(clip["poses"]), style=style_of(i, meta),
                          strength=clip.get("accent"), rng=np.random.default_rng(RULES_SEED + seed + i))
            if meta.get("mirror"):
                poses = mirror_pose(poses)
            hs.append(metrics.speed_hellinger(clip["poses"], poses))
        out[name] = float(np.nanmean(hs))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", default="data/heldout", help="corpus folder (default data/heldout)")
    ap.add_argument("--split", default=None, help="split (default: all clips)")
    ap.add_argument("--seed", type=int, default=0, help="the teacher's seed, as sgt eval --seed (default 0)")
    args = ap.parse_args(argv)
    clips = load_corpus(Path(args.corpus), args.split)
    print(f"{args.corpus} ({len(clips)} clips), seed {args.seed}: all-joint Hellinger distance of the re-seeded teacher")
    for name, h in distances(clips, args.seed).items():
        print(f"  {name:22s} {h:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

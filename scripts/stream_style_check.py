"""Requested versus achieved style: the streaming generator against the offline engine.

The offline engine meets a requested speed partly by post-processing (``postprocess.follow_speed``,
a centred low-pass of 21 frames, so 10 frames of look-ahead); the stream
(:class:`model.streaming.StreamGenerator`) decides a frame 6 frames ahead and leaves the speed
to the network. This script measures what that costs: for each style dimension and each
requested value (-2, -1, +1, +2), both engines generate every clip of a corpus split from its
timed words alone (no audio, as a client that sends only words), the style held on every
frame; achieved = the mean over the clips' speaking frames of that dimension of the motion's
style (as ``sgt eval``'s requested-versus-achieved table), with the least-squares slope:

    python scripts/stream_style_check.py [--corpus data/corpus] [--split val] [--weights FILE] [--limit N]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

LEVELS = (-2.0, -1.0, 1.0, 2.0)


def clip_words(clip) -> list:
    """The clip's timed words in order, each starting after the one before ends (the stream's rule)."""
    from core.words import TimedWord

    words: list = []
    for w in sorted(clip["meta"]["words"], key=lambda w: w["start"]):
        if w["word"].strip() and (not words or w["start"] >= words[-1].end):
            words.append(TimedWord(w["word"], float(w["start"]), float(w["end"])))
    return words


def offline(runner, words, name: str, value: float, seed: int) -> np.ndarray:
    """The neural engine on ``words`` (no audio) with style ``name`` = ``value`` on every frame."""
    from core.controls import STYLE_INDEX, ControlArrays
    from model import neural, postprocess
    from model.features import silence_features, word_features
    from model.streaming import TAIL

    n = int(np.ceil((words[-1].end + TAIL) * 15))
    arrays = ControlArrays.empty(n)
    arrays.style[:, STYLE_INDEX[name]] = value
    arrays.style_mask[:, STYLE_INDEX[name]] = 1.0
    ids, onsets = word_features(words, n)
    raw = neural.network_motion(runner, silence_features(n), ids, onsets, arrays, seed, words=words)
    return postprocess.finish(raw, arrays.pose, arrays.pose_mask, words=words, style=arrays.style,
                              style_mask=arrays.style_mask)


def stream(runner, words, name: str, value: float, seed: int) -> np.ndarray:
    """The streaming generator fed ``words`` at once, then finished."""
    from model.streaming import StreamGenerator

    gen = StreamGenerator(runner, seed=seed, style={name: value})
    return np.concatenate([gen.add_words([(w.word, w.start, w.end) for w in words]), gen.finish()])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", default="data/corpus")
    ap.add_argument("--split", default="val", choices=("train", "val", "test"))
    ap.add_argument("--weights", help="generator weights (default: the shipped ones)")
    ap.add_argument("--limit", type=int, help="only the first N clips")
    args = ap.parse_args(argv)

    from core.controls import STYLE_INDEX, STYLE_NAMES
    from model.features import word_features
    from model.runtime import load_runner
    from model.style import style as style_of
    from model.training.corpus import load_corpus

    runner = load_runner(args.weights)
    clips = [c for c in load_corpus(args.corpus, args.split)[: args.limit] if clip_words(c)]
    print(f"{len(clips)} clips of {args.corpus} ({args.split}), words only; achieved style for "
          + ", ".join(f"{v:+g}" for v in LEVELS))
    for name in STYLE_NAMES:
        for engine, run in (("offline", offline), ("stream", stream)):
            achieved = []
            for value in LEVELS:
                got = []
                for i, clip in enumerate(clips):
                    words = clip_words(clip)
                    motion = run(runner, words, name, value, i)
                    ids, _ = word_features(words, len(motion))
                    got.append(style_of(motion)[ids > 0, STYLE_INDEX[name]])
                achieved.append(float(np.concatenate(got).mean()))
            slope = float(np.polyfit(LEVELS, achieved, 1)[0])
            print(f"{name:<11} {engine:<8}" + "".join(f" {a:+6.2f}" for a in achieved) + f"   slope {slope:.2f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

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


def offline(words, name: str, value: float, seed: int, weights=None) -> np.ndarray:
    """The neural engine, as ``sgt generate`` runs it, on ``words`` (no audio) with style ``name``
    = ``value`` on every frame."""
    from core.controls import ControlArrays
    from core.skeleton import FPS
    from model import neural
    from model.generate import EngineInputs
    from model.streaming import TAIL

    arrays = ControlArrays.empty(int(np.ceil((words[-1].end + TAIL) * FPS)))
    arrays.set_style(0, arrays.n_frames, {name: value})
    return neural.generate(EngineInputs(arrays, words), seed=seed, options=neural.Options(weights=weights))


def stream(words, name: str, value: float, seed: int, weights=None) -> np.ndarray:
    """The streaming generator fed ``words`` at once, then finished."""
    from model.runtime import load_runner
    from model.streaming import StreamGenerator

    gen = StreamGenerator(load_runner(weights), seed=seed, style={name: value})
    return np.concatenate([gen.add_words([(w.word, w.start, w.end) for w in words]), gen.finish()])


def following(engine, clip_words_list, weights=None) -> dict:
    """``sgt eval``'s requested-versus-achieved result (:func:`model.training.evaluate.style_following`'s
    form) for ``engine`` (:func:`offline` or :func:`stream`) on each clip's words."""
    from core.controls import STYLE_INDEX, STYLE_NAMES
    from model.features import word_features
    from model.style import style as style_of

    out = {}
    for name in STYLE_NAMES:
        achieved = []
        for value in LEVELS:
            got = []
            for i, words in enumerate(clip_words_list):
                motion = engine(words, name, value, i, weights)
                ids, _ = word_features(words, len(motion))
                got.append(style_of(motion)[ids > 0, STYLE_INDEX[name]])
            achieved.append(float(np.concatenate(got).mean()))
        out[name] = {"requested": list(LEVELS), "achieved": achieved, "slope": float(np.polyfit(LEVELS, achieved, 1)[0])}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", default="data/corpus")
    ap.add_argument("--split", default="val", choices=("train", "val", "test"))
    ap.add_argument("--weights", help="generator weights (default: the shipped ones)")
    ap.add_argument("--limit", type=int, help="only the first N clips")
    args = ap.parse_args(argv)

    from model.training.corpus import load_corpus
    from model.training.evaluate import format_style_following

    words = [w for w in map(clip_words, load_corpus(args.corpus, args.split)[: args.limit]) if w]
    print(f"{len(words)} clips of {args.corpus} ({args.split}), their timed words only")
    for title, engine in (("offline engine (sgt generate)", offline), ("stream (sgt serve)", stream)):
        print(f"\n{title}\n" + format_style_following(following(engine, words, args.weights)), end="", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

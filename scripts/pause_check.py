"""Does the generator rest in a script's pauses? Wrist speed inside `[pause]` spans against speech.

Issue 10 asks that the wrists move at most as fast inside pauses as while speaking, with the
shipped weights (the weights trained on per-utterance z-scored audio features gestured
hardest in digital silence: 0.45 m/s at the peak of a `[pause 2s]` against 0.15 m/s while
speaking). This script compiles a script (by default one utterance with a `[pause 2s]`
mid-sentence and a `[pause 4s]` between two sentences: a long gap), generates ``--seeds``
takes with the default engine (or ``--engine NAME``, any engine of :data:`model.engines.ENGINES`,
``--weights`` for the network engines, or ``--engine stream``, the streaming service's
generator fed the utterance's timed words) and prints, over the takes,
the median, mean and peak of the wrists' speed (the mean of both wrists, m/s; frame t's speed
is the step into it) on frames inside a pause and on frames inside a word:

    python scripts/pause_check.py [FILE.sgt] [--weights FILE] [--seeds N] [--engine ENGINE|stream] [--json FILE]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from model.engines import DEFAULT_ENGINE, ENGINES

SCRIPT = (
    "guide: Welcome to the mall. The shops on this floor open at nine every morning, [pause 2s] and the food court "
    "upstairs stays open late. [pause 4s] If you need anything at all, just ask me and I will show you the way.\n"
)


def wrist_speed(poses: np.ndarray) -> np.ndarray:
    """Per-frame speed of the wrists (mean of both, m/s); frame 0 reads 0."""
    from core.skeleton import JOINTS
    from model.training.metrics import joint_speeds

    wrists = [JOINTS.index("left_wrist"), JOINTS.index("right_wrist")]
    return np.r_[0.0, joint_speeds(poses)[:, wrists].mean(axis=1)]


def span_masks(utterance) -> tuple[np.ndarray, np.ndarray]:
    """(pause, speaking) frame masks of a compiled utterance: inside a ``[pause]``; inside a word."""
    from core.skeleton import FPS

    n = utterance.n_frames
    pause = np.zeros(n, bool)
    for c in utterance.controls:
        if c.kind == "pause":
            pause[c.start_frame:c.end_frame] = True
    t = np.arange(n) / FPS
    speaking = np.zeros(n, bool)
    for w in utterance.words:
        speaking |= (t >= w.start) & (t < w.end)
    return pause, speaking & ~pause


def summary(values: np.ndarray) -> dict:
    return {"median": float(np.median(values)), "mean": float(values.mean()), "peak": float(values.max()),
            "frames": int(values.size)}


def measure(path: Path, *, seeds: int = 5, weights=None, engine: str = DEFAULT_ENGINE) -> dict:
    """Pause and speech wrist-speed summaries over every utterance with a pause and ``seeds`` takes."""
    from dsl.compiler import compile_file
    from model import neural
    from model.generate import NETWORK_ENGINES, EngineInputs, engine_function

    result = compile_file(path)
    if result.plan is None:
        raise SystemExit("\n".join(str(d) for d in result.diagnostics))
    # weights: the network engines' (default: each its shipped file); the other engines their defaults
    fn = None if engine == "stream" else engine_function(engine, neural.Options(weights=weights) if engine in NETWORK_ENGINES else None)
    in_pause, speaking = [], []
    for u in result.plan.utterances:
        pause, speech = span_masks(u)
        if not pause.any():
            continue
        inputs = EngineInputs.from_plan(u)
        for seed in range(seeds):
            if engine == "stream":
                poses = streamed(inputs.words, seed, weights)
            else:
                poses = fn(inputs, seed=seed)
            v = wrist_speed(poses)
            n = min(len(v), len(pause))  # a stream ends half a second after the last word
            in_pause.append(v[:n][pause[:n]])
            speaking.append(v[:n][speech[:n]])
    if not in_pause:
        raise SystemExit(f"{path}: no utterance has a [pause]")
    return {"pause": summary(np.concatenate(in_pause)), "speaking": summary(np.concatenate(speaking)),
            "engine": engine, "weights": weights, "seeds": seeds}


def streamed(words, seed: int, weights=None) -> np.ndarray:
    """The streaming generator's poses for timed words sent at once (no audio), then ``finish``."""
    from model.runtime import load_runner
    from model.streaming import StreamGenerator

    gen = StreamGenerator(load_runner(weights), seed=seed)
    return np.concatenate([gen.add_words([(w.word, w.start, w.end) for w in words]), gen.finish()])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("script", nargs="?", help="a .sgt script with [pause] tags (default: the built-in one above)")
    ap.add_argument("--weights", help="generator weights (default: the shipped ones)")
    ap.add_argument("--seeds", type=int, default=5, help="takes (default 5)")
    ap.add_argument("--engine", choices=(*ENGINES, "stream"), default=DEFAULT_ENGINE)
    ap.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(args.script) if args.script else Path(tmp) / "pauses.sgt"
        if not args.script:
            path.write_text(SCRIPT, encoding="utf-8")
        result = measure(path, seeds=args.seeds, weights=args.weights, engine=args.engine)
    print(f"{'wrist speed m/s':16} {'median':>7} {'mean':>7} {'peak':>7} {'frames':>7}")
    for key in ("pause", "speaking"):
        r = result[key]
        print(f"{'in ' + key if key == 'pause' else key:16} {r['median']:7.3f} {r['mean']:7.3f} {r['peak']:7.3f} {r['frames']:7d}")
    p, s = result["pause"], result["speaking"]
    print(f"({args.seeds} takes, {args.engine}) pause / speaking: median {p['median'] / s['median']:.2f}, "
          f"peak {p['peak'] / s['peak']:.2f}")
    if args.json:
        import json

        from core.fileio import atomic_write_text

        atomic_write_text(Path(args.json), json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

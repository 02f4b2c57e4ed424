"""How often does each engine gesture on a long line without marks? Strokes per 10 s against the teacher.

Five lines of 7 to 19 seconds, no controls, each spoken by three voices at three rates
(en-us at 165, en-gb at 130, en-us+f2 at 220 words per minute), are generated ``--seeds`` times
by each engine (the utterance as ``sgt generate`` makes it, started from its speaker's
listening motion where the engine takes one) and their gesture strokes counted: the motion
beats of the wrists (:func:`model.training.metrics.motion_beats`, the moments a stroke stops;
the matching engine's :func:`model.matching.stroke_ends` is the same rule), per 10 s of the
utterance. Prints each engine's mean rate and its ratio to the teacher's (``rules``) on the same
lines, the mean of the per-line ratios and its range:

    python scripts/stroke_rate_check.py [--engines matching,neural,rules] [--seeds N] [--json FILE]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

LINES = (
    ("So the way I see it, the whole thing started years ago when we first moved into the old house by the river "
     "and nobody in the family really knew what to do with all that space"),
    ("Our team spent the last three months rebuilding the checkout flow from scratch because customers kept telling "
     "us that paying for their orders took far too long and the forms asked for the same details twice"),
    ("I remember walking down to the harbour every morning before school to watch the fishing boats come in with "
     "their nets full of silver fish while the gulls screamed overhead and the old men argued about the weather and "
     "the price of diesel and whose turn it was to buy the coffee"),
    ("The new library will open next spring with reading rooms on every floor a cafe by the entrance and a garden on "
     "the roof where anyone can sit and read in the sun"),
    ("When you look at the numbers carefully you start to notice that the biggest changes did not come from the "
     "expensive campaigns at all but from the small things people said to each other at work and at home and online "
     "every single day for years and years without anyone planning any of it"),
)
VOICES = (("en-us", 165), ("en-gb", 130), ("en-us+f2", 220))


def stroke_rate(poses: np.ndarray) -> float:
    """Gesture strokes (motion beats of the wrists) per 10 s of ``poses``."""
    from core.skeleton import FPS
    from model.training.metrics import motion_beats

    return 10.0 * len(motion_beats(poses)) / (len(poses) / FPS)


def plans(lines=LINES, voices=VOICES) -> list:
    """One compiled one-line plan per line and voice (espeak-ng's word times)."""
    from model.generate import GenerateError, generate

    out = []
    for text in lines:
        for voice, rate in voices:
            source = f"@voice {voice}\n@rate {rate}\nanna: {text}\n"
            try:
                out.append(generate(source=source, engine="rules", perform=False).plan)
            except GenerateError as exc:
                raise SystemExit(f"cannot compile a line: {exc}") from None
    return out


def rates(plan_list, engine: str, seeds: int) -> np.ndarray:
    """(lines, seeds) strokes per 10 s of ``engine`` on each plan's utterance."""
    from model.generate import clips_from_plan

    return np.array([[stroke_rate(clips_from_plan(p, engine=engine, seed=s)[0].poses) for s in range(seeds)]
                     for p in plan_list])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engines", default="matching,neural,rules", help="comma-separated (default matching,neural,rules)")
    ap.add_argument("--seeds", type=int, default=3, help="takes per line (default 3)")
    ap.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = ap.parse_args()
    engines = [e.strip() for e in args.engines.split(",") if e.strip()]
    if "rules" not in engines:
        engines.append("rules")
    plan_list = plans()
    seconds = [p.n_frames / 15 for p in plan_list]
    got = {e: rates(plan_list, e, args.seeds) for e in engines}
    teacher = got["rules"].mean(1)
    result = {"lines": len(plan_list), "seconds": [min(seconds), max(seconds)], "seeds": args.seeds, "engines": {}}
    print(f"{len(plan_list)} lines of {min(seconds):.1f}-{max(seconds):.1f} s, {args.seeds} seeds each")
    print(f"{'engine':10} {'strokes/10 s':>12} {'ratio':>6} {'per line: mean':>15} {'min':>5} {'max':>5}")
    for e in engines:
        per_line = got[e].mean(1) / teacher
        r = {"strokes_per_10s": float(got[e].mean()), "ratio": float(got[e].mean() / teacher.mean()),
             "per_line_mean": float(per_line.mean()), "per_line_min": float(per_line.min()),
             "per_line_max": float(per_line.max())}
        result["engines"][e] = r
        print(f"{e:10} {r['strokes_per_10s']:12.2f} {r['ratio']:6.2f} {r['per_line_mean']:15.2f} "
              f"{r['per_line_min']:5.2f} {r['per_line_max']:5.2f}")
    if args.json:
        import json

        from core.fileio import atomic_write_text

        atomic_write_text(Path(args.json), json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

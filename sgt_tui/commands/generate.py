"""sgt generate: script -> upper-body motion (JSON or NPZ)."""

from __future__ import annotations

import argparse
import sys

HELP = "generate motion for a script (automatic gestures + your controls)"
DESCRIPTION = """\
Generate upper-body motion for every utterance of a script: automatic gestures from
the speech where you wrote nothing, your [pose:...] gestures where you wrote them, and
the requested style where you wrote <speed:...> and friends.

Output (.json or .npz, chosen by the extension): fps, joint names, and per utterance
its words, controls, joint positions (T x 10 x 3, metres, y-up) and the 27-number poses.
See docs/formats.md."""

ENGINE_HELP = "neural (default: the trained generator), keyframe (splines through your pose controls), rules (procedural)"


def register(sub) -> None:
    from sgt_tui.commands.common import SMOOTHING_CHOICES

    p = sub.add_parser("generate", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE", help="script file (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT", required=True, help="motion file to write (.json or .npz)")
    p.add_argument("--engine", default=None, help=ENGINE_HELP)
    p.add_argument("--utterance", type=int, action="append", metavar="N", help="only utterance N (0-based; repeatable)")
    p.add_argument("--seed", type=int, help="random seed (default: the script's @seed); another seed, another take")
    p.add_argument("--smoothing", choices=SMOOTHING_CHOICES, default=SMOOTHING_CHOICES[0], help="post-filter of the neural engine (default one_euro)")
    p.add_argument("--no-blend", action="store_true", help="neural engine: do not force exact pose following")
    p.add_argument("--weights", metavar="PATH", help="generator weights (default: the shipped model/weights/generator.pt)")
    p.set_defaults(run=run)


def run(args) -> int:
    from pathlib import Path

    from core.motion import MotionFileError, save_motion
    from core.skeleton import FPS
    from model.generate import GenerateError, generate_clips
    from model.neural import Options
    from sgt_tui.commands.common import existing_file, print_diagnostics
    from sgt_tui.errors import UsageError
    from sgt_tui.progress import ProgressBar

    path = existing_file(args.file)
    out = Path(args.output)
    if out.suffix.lower() not in (".json", ".npz"):
        raise UsageError(f"output must end in .json or .npz, not '{out.suffix or out.name}'")
    options = Options(smoothing=args.smoothing, blend=not args.no_blend, weights=args.weights)
    try:
        clips = generate_clips(path, engine=args.engine, utterances=args.utterance, seed=args.seed,
                               progress=ProgressBar("generate"), options=options)
    except GenerateError as exc:
        if exc.diagnostics:
            print_diagnostics(exc.diagnostics, {str(path): exc.source})
        else:
            print(f"sgt generate: error: {exc}", file=sys.stderr)
        return 1
    if args.utterance and not clips:
        raise UsageError(f"no utterance {args.utterance[0]} in {path}")
    try:
        save_motion(out, clips)
    except (MotionFileError, OSError) as exc:
        print(f"sgt generate: error: cannot write {out}: {exc}", file=sys.stderr)
        return 1
    frames = sum(len(c.poses) for c in clips)
    print(f"wrote {out}: {len(clips)} utterances, {frames} frames ({frames / FPS:.1f}s)", file=sys.stderr)
    return 0

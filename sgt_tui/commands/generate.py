"""sgt generate: script -> upper-body motion (JSON or NPZ)."""

from __future__ import annotations

import argparse
import sys

HELP = "generate motion for a script (automatic gestures + your controls)"
DESCRIPTION = """\
Generate upper-body motion for every utterance of a script: automatic gestures from
the speech where you wrote nothing, your [pose:...] gestures where you wrote them, and
the requested style where you wrote <speed:...> and friends.

Output (.json or .npz, chosen by the extension or --format; '-o -' writes JSON to
standard output): fps, joint names, per utterance its place on the performance clock
(start, audio_offset), words, controls, joint positions (T x 10 x 3, metres, y-up) and
the 27-number poses, and each speaker's continuous track over the whole performance
(listening motion between its lines). See docs/formats.md.

--threads sets torch's thread count (default 1: on a shared or small machine more threads
wait for each other; benchmarks/bench_threads.py measures it)."""

ENGINE_HELP = ("matching (default: motion matching over a database of takes, the shipped one or --database), neural (the "
               "trained network), keyframe (splines through your pose controls), rules (the procedural teacher)")


def register(sub) -> None:
    from sgt_tui.commands.common import ENGINE_CHOICES, add_database_option, add_post_options, add_seed_option, utterance_number

    p = sub.add_parser("generate", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE", help="script file (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT", required=True,
                   help="motion file to write (.json or .npz; '-': JSON on standard output)")
    p.add_argument("--format", choices=("json", "npz"), help="output format (default: from OUT's extension)")
    p.add_argument("--engine", choices=ENGINE_CHOICES, default=None, help=ENGINE_HELP)
    p.add_argument("--utterance", type=utterance_number, action="append", metavar="N", help="only utterance N (0-based; repeatable)")
    add_seed_option(p, "random seed (default: the script's @seed); another seed, another take")
    add_post_options(p)
    p.add_argument("--weights", metavar="PATH", help="generator weights (default: the shipped model/weights/generator.pt)")
    add_database_option(p)
    add_threads_option(p)
    p.add_argument("--auto-gestures", action="store_true",
                   help="where the script has no mark, the gestures its words call for ('sgt suggest' shows them)")
    p.set_defaults(run=run)


def add_threads_option(p) -> None:
    from sgt_tui.commands.common import positive_int

    p.add_argument("--threads", type=positive_int, metavar="N",
                   help="torch threads for the neural engine (default 1, measured best under load)")


def run(args) -> int:
    from core.skeleton import FPS
    from model.neural import Options
    from sgt_tui.commands.clips import generate_script
    from sgt_tui.commands.common import database_option, existing_file, inputs_of, output_file, output_format, shown

    path = existing_file(args.file)
    fmt = output_format(args.output, args.format, ("json", "npz"))
    weights = str(existing_file(args.weights)) if args.weights else None
    database = database_option(args.database, args.engine)
    out = output_file(args.output, binary=fmt == "npz", inputs=inputs_of(path, weights, database))
    options = Options(smoothing=args.smoothing, blend=not args.no_blend, weights=weights, threads=args.threads,
                      take_posture=not args.no_take_posture, database=database)
    take = generate_script(path, engine=args.engine, utterances=args.utterance, seed=args.seed, options=options,
                           auto_gestures=args.auto_gestures)
    take.save(out, format=fmt)
    frames = take.plan.n_frames
    print(f"wrote {shown(out)}: {len(take.clips)} utterances, {len(take.tracks)} speaker track(s), "
          f"{frames} frames ({frames / FPS:.1f}s)", file=sys.stderr)
    return 0

"""sgt compile: script -> plan.json (words, controls) and control arrays (.npz)."""

from __future__ import annotations

import argparse
import sys

from core.counting import plural

HELP = "compile a script into a timing and control plan"
DESCRIPTION = """\
Compile a script: synthesize (or read) the speech, time every word, and turn the
pose and style marks into per-frame controls at 15 fps.

The plan (JSON) lists for each utterance its speaker, text, duration, words with
start/end seconds, and controls (kind, name, start_frame, end_frame exclusive,
source line/col, options). --npz writes the arrays the generator consumes:
pose_I (T x 27), pose_mask_I (T), style_I (T x 3), style_mask_I (T x 3), bone_mask_I (T x 9)."""


def register(sub) -> None:
    from sgt_tui.commands.common import utterance_number

    p = sub.add_parser("compile", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE", help="script file (.sgt)")
    p.add_argument("-o", "--output", metavar="PLAN", help="write the plan JSON here (default, or '-': standard output)")
    p.add_argument("--npz", metavar="FILE", help="also write the control arrays as .npz ('-': standard output, not a terminal)")
    p.add_argument("--utterance", type=utterance_number, action="append", metavar="N", help="only utterance N (the first is 1; repeatable)")
    p.add_argument("--estimate", action="store_true", help="estimate word times from the text instead of synthesizing speech")
    p.add_argument("--format", choices=("text", "json"), default="text", help="diagnostics format (default text, on stderr)")
    p.add_argument("--max-errors", type=int, metavar="N", default=None,
                   help="show at most N problems per file and count the rest (text default 50, JSON all; 0: all)")
    p.set_defaults(run=run)


def run(args) -> int:
    from pathlib import Path

    from dsl.compiler import compile_file
    from sgt_tui.commands.check import DEFAULT_MAX
    from sgt_tui.commands.common import (
        STDOUT,
        check_utterances,
        exit_code,
        max_per_file,
        one_stdout,
        inputs_of,
        output_file,
        print_diagnostics,
        shown,
    )
    from core.fileio import same_file
    from sgt_tui.errors import UsageError
    from sgt_tui.progress import ProgressBar

    if args.max_errors is not None and args.max_errors < 0:
        raise UsageError("--max-errors must be 0 (show all) or more")
    path = Path(args.file)  # a missing or unreadable script is a diagnostic (exit 1), as in sgt check
    target = STDOUT if args.output is None else args.output  # -o "" is an empty name, refused: not standard output
    one_stdout(**{"-o" if args.output is not None else "the plan (no -o)": target, "--npz": args.npz})
    inputs = inputs_of(path)
    plan_out = output_file(target, "-o", inputs=inputs)
    npz_out = output_file(args.npz, "--npz", binary=True, inputs=inputs) if args.npz is not None else None
    if args.output and args.npz and (args.output == args.npz or same_file(args.output, args.npz)):
        raise UsageError(f"-o and --npz name one file ({args.npz}): the plan would overwrite the arrays")
    result = compile_file(path, timing="estimate" if args.estimate else "speech", progress=ProgressBar("speech"), utterances=args.utterance)
    diags = result.diagnostics
    if result.plan is not None:
        check_utterances(result.script, args.utterance)
    print_diagnostics(diags, {str(path): result.script.source}, args.format,
                      max_per_file=max_per_file(args.max_errors, args.format, DEFAULT_MAX))
    if result.plan is None:
        return exit_code(diags) or 1
    plan = result.plan
    plan.save_json(plan_out)
    if npz_out is not None:
        plan.save_npz(npz_out)
    if args.output and args.output != STDOUT:
        frames = sum(u.n_frames for u in plan.utterances)
        seconds = sum(u.duration for u in plan.utterances)
        n_ctl = sum(len(u.controls) for u in plan.utterances)
        extra = f" and {shown(npz_out)}" if npz_out is not None else ""
        print(f"wrote {shown(args.output)}{extra}: {plural(len(plan.utterances), 'utterance')}, {seconds:.1f}s, "
              f"{plural(frames, 'frame')}, {plural(n_ctl, 'control')}", file=sys.stderr)
    return exit_code(diags)

"""sgt check: report every problem in one or more scripts."""

from __future__ import annotations

import argparse
import sys

HELP = "check scripts and report every problem (file:line:col)"
DESCRIPTION = """\
Check .sgt scripts and report every problem in one run: syntax, unknown gestures,
presets and style names (with suggestions), values out of range, unclosed or
mismatched tags, and pose controls that overlap in time.

By default word times are estimated from the text (fast, no speech engine), so an
overlap is reported as a warning. With --timing the real speech timing is used
(espeak-ng or the recordings; cached), exactly as 'sgt compile' does."""


def register(sub) -> None:
    p = sub.add_parser("check", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("files", nargs="+", metavar="FILE", help="script files (.sgt)")
    p.add_argument("--format", choices=("text", "json"), default="text", help="diagnostics as text (default) or JSON on stdout")
    p.add_argument("--timing", action="store_true", help="use real speech timing (slower; exact overlap checks)")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing for clean files")
    p.set_defaults(run=run)


def run(args) -> int:
    import gc

    # A long script's analysis holds a few objects per word and makes next to no reference
    # cycles, yet the collector's full passes over them took half the run of `sgt check`.
    # Paused while checking (not with --timing, which runs the speech tools), restored after.
    pause = gc.isenabled() and not args.timing
    if pause:
        gc.disable()
    try:
        return _check(args)
    finally:
        if pause:
            gc.enable()


def _check(args) -> int:
    from dsl.compiler import compile_file
    from sgt_tui.commands.common import existing_file, exit_code, print_diagnostics
    from sgt_tui.progress import ProgressBar

    paths = [existing_file(f) for f in args.files]
    all_diags = []
    sources = {}
    for path in paths:
        bar = ProgressBar(f"timing {path.name}") if args.timing else None
        result = compile_file(path, timing="speech" if args.timing else "estimate", progress=bar)
        all_diags.extend(result.diagnostics)
        sources[str(path)] = result.script.source
        if args.format == "text" and not args.quiet and not result.diagnostics:
            n = len(result.script.utterances)
            print(f"{path}: ok ({n} utterance{'s' if n != 1 else ''})")
    print_diagnostics(all_diags, sources, args.format, stream=sys.stdout)
    return exit_code(all_diags)

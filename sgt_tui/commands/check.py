"""sgt check: report every problem in one or more scripts."""

from __future__ import annotations

import argparse
import sys

from core.counting import plural

HELP = "check scripts and report every problem (file:line:col)"
DESCRIPTION = """\
Check .sgt scripts and report every problem in one run: syntax, unknown gestures,
presets, style names and voices (with suggestions), values out of range, unclosed or
mismatched tags, recordings and timings files that cannot be read or do not match,
lines that look like a speaker but are not, invisible characters, and pose controls
that overlap in time.

It runs the same analysis as 'sgt compile', 'say', 'generate' and the editor, so a
script that passes here compiles. Word times are estimated from the text (fast, no
speech engine); overlapping pose controls are warnings everywhere, resolved the same
way by every command. With --timing the real speech timing is used (espeak-ng or the
recordings; cached), exactly as 'sgt compile' does.

A file that cannot be read is reported and the others are still checked.
'sgt explain CODE' explains a diagnostic's code (e.g. SGT201)."""

#: Diagnostics shown per file in text output unless --max-errors says otherwise.
DEFAULT_MAX = 50


def register(sub) -> None:
    p = sub.add_parser("check", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("files", nargs="+", metavar="FILE", help="script files (.sgt)")
    p.add_argument("--format", choices=("text", "json"), default="text", help="diagnostics as text (default) or JSON on stdout")
    p.add_argument("--timing", action="store_true", help="use real speech timing (slower; exact overlap warnings)")
    p.add_argument("--max-errors", type=int, metavar="N", default=None,
                   help=f"show at most N problems per file and count the rest (text default {DEFAULT_MAX}, JSON all; 0: all)")
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
    from pathlib import Path

    from core.diagnostics import summary
    from dsl.compiler import compile_file
    from sgt_tui.commands.common import exit_code, max_per_file, print_diagnostics
    from sgt_tui.errors import UsageError
    from sgt_tui.progress import ProgressBar

    if args.max_errors is not None and args.max_errors < 0:
        raise UsageError("--max-errors must be 0 (show all) or more")
    limit = max_per_file(args.max_errors, args.format, DEFAULT_MAX)
    all_diags = []
    sources = {}
    for name in args.files:
        path = Path(name)
        bar = ProgressBar(f"timing {path.name}") if args.timing else None
        result = compile_file(path, timing="speech" if args.timing else "estimate", progress=bar)
        all_diags.extend(result.diagnostics)
        sources[str(path)] = result.script.source
        if args.format == "text":
            if result.diagnostics:
                print_diagnostics(result.diagnostics, sources, stream=sys.stdout, max_per_file=limit, summarise=False)
            elif not args.quiet:
                n = len(result.script.utterances)
                print(f"{path}: ok ({plural(n, 'utterance')})")
    if args.format == "json":
        print_diagnostics(all_diags, sources, "json", max_per_file=limit)
    elif all_diags:
        print(summary(all_diags))
    return exit_code(all_diags)

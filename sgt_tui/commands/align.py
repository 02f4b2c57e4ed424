"""sgt align: write the aligner's word times of a script's recordings as timings files."""

from __future__ import annotations

import argparse

HELP = "write the word times the aligner finds in a script's recordings, as timings files to review"
DESCRIPTION = """\
For every utterance of the script FILE spoken from a recording (@audio REC, without
timings=), align the utterance's words to the recording with pocketsphinx, exactly as
'sgt check' and 'sgt compile' do (the same cached alignment), and write the words'
times as a timings file: REC's name with .timings.json (--format json, the default)
or .TextGrid (--format textgrid, which Praat opens beside the recording), in REC's
folder or in -o DIR.

It says whether the check accepts the transcript. When the check rejects a transcript
that you know is right (the aligner is not perfect: docs/language.md measures how often),
this is the way forward: review the times (listen in Praat, or read them), correct any
that are off, and name the file on the directive, '@audio REC timings=TIMINGS'; the
recording is then timed by the file and not checked by the aligner. Existing timings
files are never replaced without --force (a file that appears while the aligner works is
not replaced either). A symbolic link where a timings file goes (dangling or not) is
refused, with or without --force: sgt never writes through a link it did not make; remove
it, or write elsewhere with -o DIR."""

def register(sub) -> None:
    from dsl.speech.recording import TIMINGS_SUFFIX
    from sgt_tui.commands.common import utterance_number

    p = sub.add_parser("align", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE", help="script file (.sgt)")
    p.add_argument("-o", "--out-dir", metavar="DIR", help="folder for the timings files (default: each recording's own folder)")
    p.add_argument("--format", choices=tuple(TIMINGS_SUFFIX), default="json",
                   help="json: a list of {word, start, end} (default); textgrid: a Praat TextGrid with a 'words' tier")
    p.add_argument("--utterance", type=utterance_number, action="append", metavar="N",
                   help="only utterance N (0-based; repeatable)")
    p.add_argument("--force", action="store_true", help="replace timings files that exist")
    p.set_defaults(run=run)


def run(args) -> int:
    import os
    import sys

    from core.fileio import OutputError, OutputExists
    from dsl.compiler import load_script
    from dsl.resources import shown_from
    from dsl.speech import SpeechError
    from dsl.speech.recording import aligner_timings, check_timings_target, timings_path, write_timings_file
    from sgt_tui.commands.common import (
        check_utterances,
        existing_file,
        inputs_of,
        output_file,
        output_folder,
        print_diagnostics,
        shown,
    )
    from sgt_tui.errors import UsageError

    path = existing_file(args.file)
    out_dir = output_folder(args.out_dir, "--out-dir") if args.out_dir else None
    script, _lib, diags = load_script(path, resources=False)  # (the recordings are aligned below, once)
    syntax = [d for d in script.diagnostics if d.is_error]
    if script.header is None or syntax:
        print_diagnostics(syntax or diags, {str(path): script.source})
        print(f"sgt align: fix these first ('sgt check {path}' lists every problem)", file=sys.stderr)
        return 1
    check_utterances(script, args.utterance)
    chosen = [u for u in script.utterances if not args.utterance or u.index in args.utterance]
    todo = [u for u in chosen if u.audio is not None and u.audio.timings is None]
    for u in chosen:
        if u.audio is not None and u.audio.timings is not None:
            print(f"[{u.index}] line {u.line}: timed by {u.audio.timings}: skipped", file=sys.stderr)
    if not todo:
        if args.utterance:
            raise UsageError(f"no utterance of {', '.join(map(str, args.utterance))} is spoken from a recording "
                             "without timings=: nothing to align")
        print(f"{shown(path)} has no recording without timings= to align (@audio FILE before an utterance)", file=sys.stderr)
        return 0
    targets = {}  # timings file -> the utterance that writes it
    inputs = inputs_of(path)
    for u in todo:
        target = timings_path(u.audio.path, args.format, out_dir)
        if target in targets:
            raise UsageError(f"utterances {targets[target].index} and {u.index} would both write {target}: "
                             "give them recordings of other names, or use --utterance")
        check_timings_target(target)  # a link there: refused with one line, --force or not
        if os.path.lexists(target) and not args.force:
            raise UsageError(f"{target} exists (a timings file you may have corrected): add --force to replace it, "
                             "or write elsewhere with -o DIR")
        output_file(str(target), "--out-dir", inputs=inputs)
        targets[target] = u
    failed = 0
    for target, u in targets.items():
        try:
            text, times, rejection = aligner_timings(u.audio.path, u.text, u.word_spans, args.format)
        except SpeechError as exc:
            print(f"[{u.index}] line {u.line}: {exc.message}", file=sys.stderr)
            failed += 1
            continue
        try:
            write_timings_file(target, text, replace=args.force)
        except OutputExists:
            print(f"[{u.index}] line {u.line}: {target} appeared while the recording was aligned: not replaced "
                  "(add --force to replace it)", file=sys.stderr)
            failed += 1
            continue
        except OutputError as exc:
            print(f"[{u.index}] line {u.line}: {exc}", file=sys.stderr)
            failed += 1
            continue
        named = shown_from(target.resolve(), path)
        print(f"[{u.index}] line {u.line}: wrote {shown(target)}: {len(times)} words, "
              f"{times[0][0]:.2f}-{times[-1][1]:.2f} s" if times else f"[{u.index}] line {u.line}: wrote {shown(target)}")
        if rejection is None:
            print("    the check accepts this transcript (no timings file is needed; with one, its times are used as written)")
        else:
            print(f"    the check REJECTS this transcript: {rejection}")
            print(f"    if the transcript is right, review these times and use them: @audio {shown_from(u.audio.path, path)} "
                  f"timings={named}")
    return 1 if failed else 0


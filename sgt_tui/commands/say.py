"""sgt say: synthesize (or read) the speech of a script and print its word timings."""

from __future__ import annotations

import argparse

HELP = "synthesize the speech and print the word timing table"
DESCRIPTION = """\
Speak every utterance of a script with espeak-ng (or read its @audio recording),
write one WAV per utterance, and print each word with its start and end time.
Results are cached by content, so running it again is instant.

--mix OUT.wav also writes the whole performance as one WAV: every utterance's speech at
its place on the performance clock (the gaps of @gap between lines), so that its sample
0 plays with frame 0 of the motion `sgt generate` makes (and it lasts as long)."""


def register(sub) -> None:
    from sgt_tui.commands.common import utterance_number

    p = sub.add_parser("say", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE", help="script file (.sgt)")
    p.add_argument("-o", "--out-dir", metavar="DIR", help="folder for the WAV files (default: ./STEM_speech; created if missing)")
    p.add_argument("--utterance", type=utterance_number, action="append", metavar="N", help="only utterance N (0-based; repeatable)")
    p.add_argument("--json", action="store_true", help="print the words as JSON instead of a table")
    p.add_argument("--mix", metavar="OUT.wav", help="also write the whole performance as one WAV, on the motion's clock ('-': standard output)")
    p.set_defaults(run=run)


def run(args) -> int:
    from pathlib import Path

    from core.fileio import Inside, atomic_write, json_text
    from dsl.compiler import compile_file
    from sgt_tui.commands.common import (
        STDOUT,
        check_utterances,
        existing_file,
        exit_code,
        inputs_of,
        output_file,
        output_folder,
        print_diagnostics,
        shown,
    )
    from sgt_tui.errors import UsageError
    from sgt_tui.progress import ProgressBar

    path = existing_file(args.file)
    if args.mix is not None and args.mix != STDOUT and Path(args.mix).suffix.lower() != ".wav":
        raise UsageError(f"--mix {args.mix}: expected a .wav file")
    if args.mix == STDOUT and args.json:
        raise UsageError("--mix - and --json both write to standard output: write the mix to a file")
    mix_out = output_file(args.mix, "--mix", binary=True, inputs=inputs_of(path)) if args.mix is not None else None
    out_dir = output_folder(args.out_dir or f"{path.stem}_speech")
    result = compile_file(path, timing="speech", progress=ProgressBar("speech"), utterances=args.utterance)
    if result.plan is not None:
        check_utterances(result.script, args.utterance)
    print_diagnostics(result.diagnostics, {str(path): result.script.source})
    if result.plan is None:
        return exit_code(result.diagnostics) or 1
    report = []
    # -o DIR: the user's folder, written as a named output is (a link, FIFO or device there is
    # theirs); the default folder is sgt's: no link planted in it is followed
    folder = Inside(out_dir, create=True) if args.out_dir is None else None
    try:
        for u in result.plan.utterances:
            wav = out_dir / f"{path.stem}_{u.index:03d}.wav"
            if u.audio_path is not None and Path(u.audio_path).resolve() != wav.resolve():
                data = Path(u.audio_path).read_bytes()
                if folder is not None:
                    folder.write(wav.name, data)
                else:
                    atomic_write(wav, data)
            # the plan's words are on the motion timeline (after the lead-in); the table is the audio's
            lead = u.lead_in
            speech_end = u.duration - u.speech.get("tail", 0.0) - lead
            report.append({"index": u.index, "speaker": u.speaker, "text": u.text, "audio": str(wav),
                           "duration": round(speech_end, 3), "start": round(u.start + lead, 6),
                           "words": [w.shifted(-lead).to_dict() for w in u.words]})
    finally:
        if folder is not None:
            folder.close()
    if mix_out is not None:
        import sys

        from dsl.speech.audio import wav_bytes
        from renders.audio_mix import mix

        samples, rate = mix([(u.audio_path, u.start + u.audio_offset) for u in result.plan.utterances], result.plan.n_frames)
        atomic_write(mix_out, wav_bytes(samples, rate))
        print(f"wrote {shown(mix_out)}: {len(samples) / rate:.2f} s at {rate} Hz, "
              f"{result.plan.n_frames} motion frames", file=sys.stderr)
        if args.mix == STDOUT:
            return exit_code(result.diagnostics)
    if args.json:
        print(json_text(report, indent=2))
        return exit_code(result.diagnostics)
    for r in report:
        # what is spoken, after who speaks it: a line without a speaker says so, so that a name
        # it speaks ('guide:[pose:nod] Yes.' says "guide") never reads as its speaker
        who = f"{r['speaker']}: " if r["speaker"] else "(no speaker) "
        print(f"[{r['index']}] {who}{r['text']}")
        print(f"    {r['audio']}  ({r['duration']:.2f}s, starts at {r['start']:.2f}s in the performance)")
        print(f"    {'word':<20} {'start':>7} {'end':>7}")
        for w in r["words"]:
            print(f"    {w['word']:<20} {w['start']:7.3f} {w['end']:7.3f}")
        print()
    return exit_code(result.diagnostics)

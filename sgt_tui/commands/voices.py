"""sgt voices: the voices (espeak-ng's and piper's) a script may name with @voice."""

from __future__ import annotations

import argparse

from core.counting import plural

HELP = "list the speech voices for @voice"
DESCRIPTION = """\
List the voices '@voice' accepts with their descriptions: the installed espeak-ng's
(a language code such as en-us, en-gb or fr; add +VARIANT for another timbre, en-us+m3,
en-gb+f2: --variants lists the variants) and the natural piper voice joe (American
English; the 'piper' extra, which it says when it is not installed). 'sgt check'
checks every @voice against these lists (a name longer than 64 characters, or a
variant that is not installed, is refused before the speech engine sees it)."""


def register(sub) -> None:
    p = sub.add_parser("voices", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("filter", nargs="?", metavar="TEXT", help="only voices whose name or description contains TEXT")
    p.add_argument("--variants", action="store_true", help="list the voice variants (the names after '+') instead")
    p.add_argument("--json", action="store_true", help="print the voices as JSON")
    p.set_defaults(run=run)


def run(args) -> int:
    import json
    import sys

    from dsl.speech import SpeechError
    from dsl.speech.synth import variant_table, voice_table

    what = "variant" if args.variants else "voice"
    try:
        table = variant_table() if args.variants else voice_table()
    except SpeechError as exc:
        print(f"sgt voices: error: {exc.message}", file=sys.stderr)
        return 1
    if args.filter:
        needle = args.filter.lower()
        table = [(n, d) for n, d in table if needle in n.lower() or needle in d.lower()]
    if args.json:
        print(json.dumps([{"name": n, "description": d} for n, d in table], indent=2, ensure_ascii=False))
        return 0
    width = max([4] + [len(n) for n, _ in table])
    for name, desc in table:
        print(f"{name:<{width}}  {desc}")
    print(plural(len(table), what) + (f" matching '{args.filter}'" if args.filter else "")
          + (" (add one to a voice: @voice en-us+NAME)" if args.variants else ""))
    return 0

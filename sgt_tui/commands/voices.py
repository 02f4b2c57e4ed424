"""sgt voices: the espeak-ng voices a script may name with @voice."""

from __future__ import annotations

import argparse

HELP = "list the speech voices for @voice"
DESCRIPTION = """\
List the voices of the installed espeak-ng: the names '@voice' accepts (a language
code such as en-us, en-gb or fr) with the voice's description. Add +VARIANT for
another timbre (en-us+m3, en-gb+f2; 'espeak-ng --voices=variant' lists them).
'sgt check' checks every @voice against this list."""


def register(sub) -> None:
    p = sub.add_parser("voices", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("filter", nargs="?", metavar="TEXT", help="only voices whose name or description contains TEXT")
    p.add_argument("--json", action="store_true", help="print the voices as JSON")
    p.set_defaults(run=run)


def run(args) -> int:
    import json
    import sys

    from dsl.speech import SpeechError
    from dsl.speech.synth import voice_table

    try:
        table = voice_table()
    except SpeechError as exc:
        print(f"sgt voices: error: {exc.message}", file=sys.stderr)
        return 1
    if args.filter:
        needle = args.filter.lower()
        table = [(n, d) for n, d in table if needle in n or needle in d.lower()]
    if args.json:
        print(json.dumps([{"name": n, "description": d} for n, d in table], indent=2, ensure_ascii=False))
        return 0
    width = max([4] + [len(n) for n, _ in table])
    for name, desc in table:
        print(f"{name:<{width}}  {desc}")
    print(f"{len(table)} voice{'s' if len(table) != 1 else ''}" + (f" matching '{args.filter}'" if args.filter else ""))
    return 0

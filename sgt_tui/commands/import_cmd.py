"""sgt import: BML or SSML -> an .sgt script."""

from __future__ import annotations

import sys

HELP = "turn a BML or SSML file into a script"
DESCRIPTION = """\
Turn the behaviour of a BML file (.bml, .xml with <bml> blocks) or the marks of an SSML file
(.ssml) into an .sgt script:

  BML   each <speech> is a line (its speaker the block's characterId); a <gesture> or <head>
        becomes [pose:NAME] at the sync point its stroke (else its start) refers to, a <gaze>
        [look:TARGET], a <faceLexeme> <face:NAME>...</face>; lexemes as docs/formats.md#bml-and-ssml
        maps them (CLASS=name, the gesture's name), or through --map
  SSML  the text of <speak> is one line; <mark name="wave"/> becomes [pose:wave] (a gesture's
        name, a mark written out such as "pose:wave x2" or "look:left", or through --map),
        <break> a [pause]

Whatever cannot be mapped is reported as FILE:LINE:COL, one line each, and nothing is written
(exit status 1); what is only partly kept (the text of <prosody>) is a warning. XML with a
document type or entities is refused: nothing outside the file is read.

--map FILE: TOML, each key a lexeme or mark name, each value a mark:
  "deictic=you" = "pose:point_front"
  greet = "pose:wave x2"
"""


def register(sub) -> None:
    p = sub.add_parser("import", help=HELP, description=DESCRIPTION, formatter_class=_raw())
    p.add_argument("input", metavar="FILE", help="a .bml or .ssml file (.xml: by its root element)")
    p.add_argument("-o", "--output", metavar="OUT", required=True, help="the script to write (.sgt; '-': standard output)")
    p.add_argument("--map", metavar="FILE", help="TOML: lexeme or mark name -> sgt mark")
    p.add_argument("--speaker", default="agent", metavar="NAME", help="the speaker of SSML and of BML blocks without "
                                                                      "a characterId (default: agent)")
    p.set_defaults(run=run)


def _raw():
    import argparse

    return argparse.RawDescriptionHelpFormatter


def run(args) -> int:
    from core.counting import plural
    from core.fileio import atomic_write_text
    from core.reading import read_bytes
    from dsl.bml import bml_script
    from dsl.markup import MarkMap, Problem, load_mark_map, script_text
    from dsl.ssml import ssml_utterance
    from dsl.xmlread import XmlError, parse_xml
    from library import load_library
    from sgt_tui.commands.common import inputs_of, output_file, shown
    from sgt_tui.errors import InputError

    out = output_file(args.output, inputs=inputs_of(args.input, args.map))
    problems: list[Problem] = []
    marks = MarkMap()
    if args.map is not None:
        marks, problems = load_mark_map(_text(read_bytes(args.map, "configuration"), args.map), args.map)
    data = read_bytes(args.input, "markup")
    try:
        root = parse_xml(data)
    except XmlError as exc:
        raise InputError(f"{args.input}:{exc.line}:{exc.col}: {exc.message}") from None
    library = load_library()
    if root.tag == "speak":
        utterance, found = ssml_utterance(root, args.input, marks, library)
        problems += found
        text, found = script_text([utterance], args.speaker)
    else:
        text, found = bml_script(root, args.input, marks, library, args.speaker)
    problems += found
    for p in problems:
        print(p, file=sys.stderr)
    errors = [p for p in problems if not p.warning]
    if errors:
        print(f"{args.input}: {plural(len(errors), 'element')} above cannot be imported: nothing written", file=sys.stderr)
        return 1
    atomic_write_text(out, text)
    print(f"wrote {shown(out)}: {plural(text.count(chr(10)), 'line')}", file=sys.stderr)
    return 0


def _text(data: bytes, path: str) -> str:
    from sgt_tui.errors import InputError

    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not UTF-8 text (byte {exc.start})") from None

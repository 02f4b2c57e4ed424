"""sgt suggest: gestures chosen from the words, written into the script for review."""

from __future__ import annotations

import argparse
import sys

from core.counting import plural

HELP = "suggest gestures from the words where the script has no mark, as a script to review"
DESCRIPTION = """\
Where the author left no mark, put the library gestures the words call for: counting
("first", "two"), deixis ("I", "you", "here", "there", "left", "up", "behind"), negation
("no", "never"), size ("huge", "tiny"), judgement ("great", "terrible"), greetings and
farewells, questions ("what", "where" in a question), contrast ("but", "however"), emphasis
("really"), change ("rise", "dropped"), together, apart, in a circle. Each word is read for
its sense first: "turn right" points and "the right answer" does not; "one ticket" counts
and "one moment", "one of them", "from one to ten" do not; "I'll be right back" is no
place; a "you" in "if you press ..." is nobody in particular; under a negation the
negation gets the gesture. Words the table lacks reach it through WordNet ("gigantic"
finds big, "awful" thumbs down) where it is installed. At most one mark per three words
of a line, the author's included (a counted list counts on, a finger a word), never within
two words of another mark nor in the sentence of an author's mark of the same meaning.
The table is library/words.toml, extended by a words.toml in your gesture folders
(docs/library.md, "Gestures from words").

  sgt suggest lobby.sgt -o lobby.suggested.sgt   the script with the marks inserted:
                                                 review it as a diff, keep what you like
  sgt suggest lobby.sgt --format json            the suggestions (line, column, gesture,
                                                 the word that called it, its kind, sense)
  sgt suggest lobby.sgt --explain -o out.sgt     and, on standard error, which word and
                                                 which sense called each gesture

Nothing else in the script changes: '[pose:NAME] ' is inserted before each word.
'sgt generate --auto-gestures' generates with them without writing the script."""


def register(sub) -> None:
    p = sub.add_parser("suggest", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE", help="script file (.sgt)")
    p.add_argument("-o", "--output", metavar="OUT.sgt", help="write the script with the suggestions ('-' or none: standard output)")
    p.add_argument("--format", choices=("script", "json"), default="script",
                   help="the script with the marks (default), or the suggestions as JSON")
    p.add_argument("--explain", action="store_true",
                   help="say on standard error which word and which sense called each gesture, and where it came from")
    p.add_argument("--dir", action="append", default=[], metavar="D", help="extra gesture folder (its words.toml too)")
    p.set_defaults(run=run)


def run(args) -> int:
    import json
    from pathlib import Path

    from core.fileio import atomic_write
    from sgt_tui.commands.common import STDOUT, inputs_of, output_file, print_diagnostics
    from sgt_tui.suggesting import SuggestError, suggestions_for

    path = Path(args.file)
    target = STDOUT if args.output is None else args.output
    out = output_file(target, "-o", inputs=inputs_of(path))
    try:
        _script, found, text = suggestions_for(path, args.dir)
    except SuggestError as exc:
        if exc.diagnostics:
            print_diagnostics(exc.diagnostics, exc.sources)
        else:
            print(f"sgt suggest: error: {exc}", file=sys.stderr)
        return 1
    if args.explain:
        from library.lexicon import find_lexicon

        for s in found:
            print(f"{path}:{s.explain()}", file=sys.stderr)
        if find_lexicon() is None:
            print("sgt suggest: note: no WordNet database installed (Debian: apt install wordnet-base): "
                  "words outside the table find no neighbour", file=sys.stderr)
    if args.format == "json":
        data = json.dumps({"file": str(path), "suggestions": [s.to_dict() for s in found]}, indent=1, ensure_ascii=False)
        atomic_write(out, (data + "\n").encode("utf-8"))
    else:
        atomic_write(out, text.encode("utf-8"))
    where = "" if target == STDOUT else f" into {target}"
    lines = len({s.line for s in found})
    print(f"{plural(len(found), 'gesture')} suggested on {plural(lines, 'line')}"
          f"{where}", file=sys.stderr)
    return 0

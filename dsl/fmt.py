"""The canonical layout of a script (``sgt fmt``, the language server's formatting).

One layout, whatever the input's spacing (docs/language.md, "Canonical layout"):

- **tags**: no spaces inside brackets, one space between a tag's parts:
  ``[ pose : wave  hold = 1s x2 ]`` is ``[pose:wave x2 hold=1s]``, ``< speed : -1 >`` is
  ``<speed:-1>``, ``</ speed >`` is ``</speed>``; values are kept as written;
- **option order**: a pose's speed (``x1``/``x2``/``x3``), then ``flip``, then ``hold=``, in the
  order the language documents (a stable sort: an option given twice keeps its order, so the
  last one still wins); a tag with an unknown or malformed option keeps its order. Style
  items are never reordered (the first names the span, and later items override earlier
  ones);
- **text**: runs of spaces and tabs are one space (how much space is between two words is not
  spoken); no trailing whitespace;
- **speakers**: ``name: text`` (no space before the colon, one after it);
- **directives**: ``@name`` and its arguments one space apart; ``SPEAKER: VALUE`` with the
  colon on the name; ``@preset NAME = ITEMS``;
- **continuation lines**: indented by four spaces;
- **comments**: their text kept as written; a comment after code starts two spaces after
  it; a comment on a line of its own starts in column 1, or is indented by four spaces when
  it was indented;
- **blank lines**: at most one in a row, none at the start or the end; the file ends with
  one line end, of the kind its first line end was (LF by default); a byte-order mark stays.

**A line's layout depends on that line alone** (and on the statement it belongs to: a
continuation line is indented): nothing is lined up across lines, so adding, removing or
editing one line never rewrites another, and a one-line change stays a one-line diff. The only
rule that looks past a line is the blank lines' (two blank lines that meet are one).

Nothing spoken or gestured changes: every change is whitespace where the language ignores it
(inside tags, between directive arguments, between words) or an order the language defines
as the same (pose options of different kinds); tests/test_fmt.py compiles scripts before and
after and compares their plans. A script with a syntax error (:data:`SYNTAX_CODES`) is
refused (:class:`FormatError`) rather than guessed at.
"""

from __future__ import annotations

import re
from pathlib import Path

from core import rules
from core.diagnostics import Diagnostic
from dsl.directives import NAME_RE as PRESET_NAME_RE
from dsl.lines import SPEAKER_RE, split_lines, strip_comment
from dsl.parser import analyse
from dsl.scan import scan_items

#: The diagnostics that make a script unreadable for the formatter: where the grammar fails
#: (a tag it cannot read, a stray bracket, an unknown escape, a trailing backslash, a closing
#: tag that closes nothing or the wrong span), a line indented with nothing to continue, a
#: directive without a name, a tag without its name. A script with any of them is left as it
#: is: formatting text the parser did not read as the author meant would only hide the error.
SYNTAX_CODES = frozenset(r.code for r in (rules.INDENT, rules.SYNTAX, rules.STRAY_CLOSER, rules.UNCLOSED, rules.BAD_TAG,
                                          rules.BAD_ESCAPE, rules.TRAILING_BACKSLASH, rules.UNMATCHED_CLOSE,
                                          rules.MISMATCHED_CLOSE, rules.DIRECTIVE_NAME, rules.MISSING_NAME))
#: Continuation lines start with this.
INDENT = "    "
#: Spaces between code and the comment after it.
COMMENT_GAP = 2
_OPTION_RANK = {"x1": 0, "x2": 0, "x3": 0, "flip": 1, "hold": 2}
_BLANKS = re.compile(r"[ \t]+")
_ARG_RE = re.compile(r'"[^"]*"|\'[^\']*\'|\S+')  # dsl.directives' argument split, raw text
_DIRECTIVE_RE = re.compile(r"@([A-Za-z_][A-Za-z0-9_\-]*)")
_PER_SPEAKER = ("voice", "rate", "pitch")  # SPEAKER: VALUE


class FormatError(Exception):
    """The script has syntax errors; :attr:`diagnostics` are they."""

    def __init__(self, diagnostics: list[Diagnostic]) -> None:
        super().__init__(f"{len(diagnostics)} syntax error{'s' if len(diagnostics) != 1 else ''}")
        self.diagnostics = diagnostics


def syntax_errors(source: str, path: str = "<string>") -> list[Diagnostic]:
    """The problems of ``source`` that stop it being formatted (none: it can be)."""
    script = analyse(source, path, gesture_names=None, base_dir=Path(path).parent)
    return [d for d in script.diagnostics if d.code in SYNTAX_CODES]


def format_source(source: str, path: str = "<string>") -> str:
    """``source`` in the canonical layout; raises :class:`FormatError` on syntax errors."""
    errors = syntax_errors(source, path)
    if errors:
        raise FormatError(errors)
    bom = "\ufeff" if source.startswith("\ufeff") else ""
    lines = split_lines(source[len(bom):])
    newline = _line_end(source)
    codes, comments, indented = [], [], []
    for raw in lines:
        code = strip_comment(raw)
        codes.append(code)
        comments.append(raw[len(code):].rstrip())
        indented.append(raw[:1] in (" ", "\t"))

    # Statements as the language reads them (dsl.lines.split_statements): lists of line numbers.
    statements: list[list[int]] = []
    for n, code in enumerate(codes):
        if not code.strip():
            continue
        if code[0] in " \t" and statements:
            statements[-1].append(n)
        else:
            statements.append([n])
    new_code: dict[int, str] = {}
    for stmt in statements:
        first = codes[stmt[0]].rstrip()
        if first.startswith("@"):
            new_code[stmt[0]] = " ".join(_directive_tokens(first))
            continue
        text = "\n".join([first] + [codes[n].lstrip(" \t").rstrip() for n in stmt[1:]])
        pieces = _utterance(text).split("\n")
        for k, (n, piece) in enumerate(zip(stmt, pieces)):
            new_code[n] = piece if k == 0 else INDENT + piece

    out: list[str] = []
    for n in range(len(lines)):
        code, comment = new_code.get(n, ""), comments[n]
        if code and comment:
            out.append(code + " " * COMMENT_GAP + comment)
        elif comment:
            out.append((INDENT if indented[n] else "") + comment)
        else:
            out.append(code)
    kept: list[str] = []
    for line in out:
        if line or (kept and kept[-1]):
            kept.append(line)
    while kept and not kept[-1]:
        kept.pop()
    return bom + newline.join(kept) + (newline if kept else "")


def _line_end(source: str) -> str:
    m = re.search(r"\r\n|\r|\n", source)
    return m.group() if m else "\n"


# -- utterances ------------------------------------------------------------------------------

def _utterance(text: str) -> str:
    """One utterance statement (continuation lines joined by "\\n", none indented)."""
    m = SPEAKER_RE.match(text.split("\n", 1)[0])  # as dsl.lines reads it: on the first line
    if m is None:
        return _body(text)
    body = _body(text[m.end():])
    rest = body.lstrip(" \t")
    return f"{m.group(1)}:" + (" " + rest if rest and not rest.startswith("\n") else rest)


def _body(body: str) -> str:
    items, stop = scan_items(body)
    if stop is not None:  # (refused before: the analyser reports where the grammar fails)
        raise FormatError([rules.SYNTAX.at("<string>", 0, 0, char=body[stop])])
    out = []
    for kind, start, end, payload in items:
        raw = body[start:end]
        if kind == "text":
            out.append(_BLANKS.sub(" ", raw))
        elif kind == "escape" or "\n" in raw:  # a tag across lines keeps its line breaks
            out.append(raw)
        elif kind == "tag":
            out.append(_tag(*payload))
        elif kind == "style_open":
            out.append("<" + " ".join(name if value is None else f"{name}:{value}" for name, value, _, _ in payload) + ">")
        else:
            out.append("</" + "".join(payload) + ">")
    return "".join(out)


def _tag(names, args) -> str:
    head = ":".join(name for name, _ in names)
    parts = [key if value is None else f"{key}={value}" for key, value, _, _ in args]
    if names[0][0] == "pose" and all(_well_formed(key, value) for key, value, _, _ in args):
        ranks = [_OPTION_RANK[key] for key, _, _, _ in args]
        parts = [p for _, p in sorted(zip(ranks, parts), key=lambda rp: rp[0])]
    return "[" + " ".join([head] + parts) + "]"


def _well_formed(key: str, value: str | None) -> bool:
    return (key == "hold") == (value is not None) and key in _OPTION_RANK


# -- directives ------------------------------------------------------------------------------

def _directive_tokens(text: str) -> list[str]:
    """``@name`` and its arguments (raw, quotes kept), with a speaker's colon on its name and
    a preset's ``=`` standing alone; the arguments mean what they meant, since the language
    splits them at whitespace (:func:`dsl.directives.split_args`)."""
    m = _DIRECTIVE_RE.match(text)
    name = m.group(1)
    args = _ARG_RE.findall(text, m.end())
    if name in _PER_SPEAKER and len(args) >= 2 and args[1] == ":" and not args[0].startswith(("'", '"')):
        args = [args[0] + ":"] + args[2:]
    elif name == "preset" and args and not args[0].startswith(("'", '"')):
        args = _preset_args(args)
    return ["@" + name] + args


def _preset_args(args: list[str]) -> list[str]:
    first, rest = args[0], args[1:]
    if "=" in first and first != "=":
        first, _, tail = first.partition("=")
        rest = [tail] + rest if tail else rest
    elif rest and rest[0].startswith("=") and rest[0] != "=":
        rest = [rest[0][1:]] + rest[1:]
    elif rest and rest[0] == "=":
        rest = rest[1:]
    if not PRESET_NAME_RE.match(first) or not rest:  # a broken preset keeps its arguments
        return args
    return [first, "="] + rest

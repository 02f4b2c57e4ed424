"""A regular-expression scanner for well-formed utterance bodies: the fast path of the parser.

The body grammar (dsl/sgt.lark) is regular: text, escapes and flat tags. This module
recognises exactly what Lark's LALR parser with its contextual lexer accepts and builds the
same items, about ten times faster, and stops where the grammar would fail, which is where the
analyser reports a syntax error (:func:`scan_items`). tests/test_scan.py checks it against
Lark on random bodies, in both directions: it accepts exactly what Lark accepts.

Mirroring the contextual lexer:
- tokens are matched greedily and never given back (possessive quantifiers, Python 3.11);
- between the tokens of a tag only ``[ \\t\\r\\n]`` is skipped; outside tags whitespace is text;
- at a ``<`` the two-character ``</`` wins, so ``</...>`` is always a closing tag.

Items are tuples ``(kind, start, end, payload)`` with offsets into the body:

- ``("text", s, e, str)`` and ``("escape", s, e, str)``;
- ``("tag", s, e, (names, args))``: ``names`` the tag's NAMEs as ``(text, start)`` (``pose``
  and the gesture), ``args`` as ``(key, value or None, start, end)``;
- ``("style_open", s, e, items)``: items as ``(name, value or None, start, end)``;
- ``("style_close", s, e, names)``: the closing NAME as a one-element list, or empty.
"""

from __future__ import annotations

import re

_WS = r"[ \t\r\n]*"
_NAME = r"[^\W\d][\w\-]*+"
_WORD = r"[A-Za-z0-9_.+\-]++"
_ARG = rf"(?:{_WORD}{_WS}(?:={_WS}{_WORD}{_WS})?)"
_STYLE_ITEM = rf"(?:{_NAME}{_WS}(?::{_WS}{_WORD}{_WS})?)"

#: One item at the top level; the alternatives are tried in the lexer's order.
ITEM_RE = re.compile(
    r"(?P<text>[^\[\]<>\\#]++)"
    r"|(?P<escape>\\[\s\S])"
    rf"|\[{_WS}(?P<kind>{_NAME}){_WS}(?::{_WS}(?P<name>{_NAME}){_WS})?(?P<args>{_ARG}*)\]"
    rf"|</{_WS}(?P<close>{_NAME})?{_WS}>"
    rf"|<{_WS}(?P<items>{_STYLE_ITEM}+)>"
)
ARG_RE = re.compile(rf"({_WORD}){_WS}(?:={_WS}({_WORD}){_WS})?")
STYLE_ITEM_RE = re.compile(rf"({_NAME}){_WS}(?::{_WS}({_WORD}){_WS})?")


def _pairs(regex: re.Pattern, text: str, lo: int, hi: int) -> list[tuple[str, str | None, int, int]]:
    """(first, second or None, start, end) for each repetition of ``regex`` in text[lo:hi]."""
    out = []
    for m in regex.finditer(text, lo, hi):
        end = m.end(2) if m.group(2) is not None else m.end(1)
        out.append((m.group(1), m.group(2), m.start(1), end))
    return out


def scan_body(body: str) -> list[tuple] | None:
    """The items of a well-formed ``body``, or None when it is not."""
    items, stop = scan_items(body)
    return items if stop is None else None


def scan_items(body: str) -> tuple[list[tuple], int | None]:
    """The items of ``body`` up to the first place where no item can start, and that offset
    (None when the whole body is well-formed). Since the scanner accepts exactly the grammar's
    language, the offset is where the grammar fails too: the analyser reports the syntax error
    there (a ``[`` or ``<`` whose tag is malformed or unclosed, a stray ``]`` or ``>``, a
    trailing backslash), blanks it and scans again."""
    items: list[tuple] = []
    append = items.append
    pos, n = 0, len(body)
    match = ITEM_RE.match
    while pos < n:
        m = match(body, pos)
        if m is None:
            return items, pos
        end = m.end()
        group = m.lastgroup
        if group == "text":
            append(("text", pos, end, m.group()))
        elif group == "args":
            names = [(m.group("kind"), m.start("kind"))]
            if m.group("name") is not None:
                names.append((m.group("name"), m.start("name")))
            append(("tag", pos, end, (names, _pairs(ARG_RE, body, m.start("args"), end - 1))))
        elif group == "items":
            append(("style_open", pos, end, _pairs(STYLE_ITEM_RE, body, m.start("items"), end - 1)))
        elif group == "escape":
            append(("escape", pos, end, m.group()))
        else:  # "</NAME>", or "</>" (no group)
            append(("style_close", pos, end, [m.group("close")] if group else []))
        pos = end
    return items, None

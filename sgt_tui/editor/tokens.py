"""The tokens of one script line, for the editor: the language's own scanner, tolerant of typos.

Highlighting and the actions' edits look at one line at a time while the user types, so the
line is often malformed. This module cuts a line with the language's line rules
(:mod:`dsl.lines`: comments, directives, speakers) and reads its body with the language's
scanner (:func:`dsl.scan.scan_body`, the items the parser builds). Where the body is malformed,
scanning resumes after the character the scanner's item pattern cannot read; those columns are
reported in :attr:`LineTokens.bad`. No other part of the editor reads tags by hand.

Items are :mod:`dsl.scan`'s tuples with offsets turned into columns of the line:
``("text" | "escape", start, end, str)``, ``("tag", start, end, (names, args))``,
``("style_open", start, end, items)`` and ``("style_close", start, end, names)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from dsl.lines import SPEAKER_RE, strip_comment
from dsl.scan import ITEM_RE, scan_body

TAG_KINDS = ("tag", "style_open", "style_close")


@dataclass(frozen=True)
class LineTokens:
    code_end: int  # where the comment starts (the line's length when there is none)
    directive: tuple[int, int] | None  # the ``@name`` of a directive line
    speaker: tuple[int, int] | None  # ``name:`` of an utterance's first line
    items: tuple[tuple, ...]  # scanner items, columns of the line
    bad: tuple[int, ...]  # columns the scanner could not read (a stray ``[``, ``>`` ...)

    @property
    def tags(self) -> list[tuple]:
        """The ``[...]``, ``<...>`` and ``</...>`` items, in order."""
        return [it for it in self.items if it[0] in TAG_KINDS]

    def tag_at(self, col: int) -> tuple[int, int] | None:
        """(start, end) of the tag that a cursor at column ``col`` is inside (after its opening
        bracket, up to its closing one)."""
        for _, start, end, _ in self.tags:
            if start < col <= end - 1:
                return start, end
        return None

    def poses(self) -> list[tuple[int, int]]:
        """(start, end) of each ``[pose:NAME ...]`` tag."""
        return [(s, e) for kind, s, e, (names, _) in (t for t in self.tags if t[0] == "tag")
                if len(names) == 2 and names[0][0] == "pose"]


@lru_cache(maxsize=8192)
def line_tokens(line: str) -> LineTokens:
    """The tokens of one source line (without its line end)."""
    code = strip_comment(line)
    if code.startswith("@"):
        end = 1
        while end < len(code) and not code[end].isspace():
            end += 1
        return LineTokens(len(code), (0, end), None, (), ())
    start, speaker = 0, None
    if code and code[0] not in " \t":
        m = SPEAKER_RE.match(code)
        if m:
            speaker, start = (m.start(1), m.end()), m.end()
    items, bad = _items(code[start:])
    return LineTokens(len(code), None, speaker, tuple(_shifted(items, start)), tuple(b + start for b in bad))


def spoken_pieces(fragment: str) -> list[str]:
    """The plain text pieces of a piece of an utterance body (tags and escapes left out)."""
    items, _ = _items(fragment)
    return [payload for kind, _, _, payload in items if kind == "text"]


def _items(body: str) -> tuple[list[tuple], list[int]]:
    """The scanner's items of ``body``; where it is malformed, those of each readable stretch."""
    items = scan_body(body)
    if items is not None:
        return items, []
    out: list[tuple] = []
    bad: list[int] = []
    start = pos = 0
    n = len(body)
    while pos < n:
        m = ITEM_RE.match(body, pos)
        if m is not None:
            pos = m.end()
            continue
        if pos > start:  # body[start:pos] is made of whole items: the scanner reads it
            out += _shifted(scan_body(body[start:pos]) or [], start)
        bad.append(pos)
        pos = start = pos + 1
    if start < n:
        out += _shifted(scan_body(body[start:]) or [], start)
    return out, bad


def _shifted(items: list[tuple], k: int) -> list[tuple]:
    """Items with every offset (the item's and those in its payload) moved by ``k``."""
    if not k:
        return list(items)
    out = []
    for kind, s, e, payload in items:
        if kind == "tag":
            names, args = payload
            payload = ([(t, p + k) for t, p in names], [(a, b, p + k, q + k) for a, b, p, q in args])
        elif kind == "style_open":
            payload = [(a, b, p + k, q + k) for a, b, p, q in payload]
        out.append((kind, s + k, e + k, payload))
    return out

"""Syntax classes of one line of a script, for highlighting (no parser: a fast line scanner).

Classes: ``comment``, ``directive`` (``@rate``), ``speaker`` (``guide:``), ``tag`` (the
brackets and kind of ``[pose:...]``, ``[pause ...]``, ``<...>``, ``</...>``), ``name`` (a
gesture, style element or preset), ``value`` (options and values: ``x2``, ``flip``,
``hold=500ms``, ``-1``, ``300ms``) and ``escape`` (``\\[``). Every tag and tag-like piece is
recognisable without colour too: the editor shows them bold or underlined (see the theme in
:mod:`sgt_tui.app.theme`).

The scanner follows the language's line rules (:mod:`dsl.lines`): comments run from an
unescaped ``#``, directives start with ``@``, speakers are a name and a colon at the start of a
non-indented line. Tags never span lines.
"""

from __future__ import annotations

import re
from functools import lru_cache

from dsl.lines import SPEAKER_RE, strip_comment

Span = tuple[int, int, str]  # start column, end column (exclusive), class

_ITEM = re.compile(r"([A-Za-z_][A-Za-z0-9_\-]*)(?:(\s*[:=]\s*)([^\s\]>]*))?|(\S+)")
_DIRECTIVE = re.compile(r"@[A-Za-z_][A-Za-z0-9_\-]*")
_ARG = re.compile(r"\S+")


@lru_cache(maxsize=8192)
def line_spans(line: str) -> tuple[Span, ...]:
    """Highlight spans of one source line, in column order."""
    code = strip_comment(line)
    spans: list[Span] = []
    if len(code) < len(line):
        spans.append((len(code), len(line), "comment"))
    if not code.strip():
        return tuple(sorted(spans))
    if code.startswith("@"):
        m = _DIRECTIVE.match(code)
        end = m.end() if m else 1
        spans.append((0, end, "directive"))
        for a in _ARG.finditer(code, end):
            spans.append((a.start(), a.end(), "value"))
        return tuple(sorted(spans))
    start = 0
    if code[0] not in " \t":
        m = SPEAKER_RE.match(code)
        if m:
            spans.append((m.start(1), m.end(), "speaker"))
            start = m.end()
    _body(code, start, spans)
    return tuple(sorted(spans))


def _closing(code: str, i: int, closer: str) -> int | None:
    for j in range(i + 1, len(code)):
        c = code[j]
        if c == closer:
            return j
        if c in "[<":
            return None
    return None


def _body(code: str, i: int, spans: list[Span]) -> None:
    n = len(code)
    while i < n:
        c = code[i]
        if c == "\\" and i + 1 < n:
            spans.append((i, i + 2, "escape"))
            i += 2
            continue
        if c in "[<":
            j = _closing(code, i, "]" if c == "[" else ">")
            if j is None:
                spans.append((i, i + 1, "tag"))
                i += 1
                continue
            if c == "[":
                _square(code, i, j, spans)
            else:
                _angle(code, i, j, spans)
            i = j + 1
            continue
        i += 1


def _square(code: str, i: int, j: int, spans: list[Span]) -> None:
    spans.append((i, i + 1, "tag"))
    spans.append((j, j + 1, "tag"))
    inner = code[i + 1 : j]
    m = re.match(r"(\s*)([A-Za-z_][A-Za-z0-9_\-]*)(\s*:\s*([A-Za-z_][A-Za-z0-9_\-]*))?", inner)
    if not m:
        return
    base = i + 1
    spans.append((base + m.start(2), base + m.end(2), "tag"))
    rest = m.end(2)
    if m.group(4):
        spans.append((base + m.start(4), base + m.end(4), "name"))
        rest = m.end(3)
    for a in _ARG.finditer(inner, rest):
        spans.append((base + a.start(), base + a.end(), "value"))


def _angle(code: str, i: int, j: int, spans: list[Span]) -> None:
    inner_start = i + 1
    if code.startswith("</", i):
        spans.append((i, i + 2, "tag"))
        inner_start = i + 2
    else:
        spans.append((i, i + 1, "tag"))
    spans.append((j, j + 1, "tag"))
    for m in _ITEM.finditer(code, inner_start, j):
        if m.group(1):
            spans.append((m.start(1), m.end(1), "name"))
            if m.group(3):
                spans.append((m.start(3), m.end(3), "value"))
        elif m.group(4):
            spans.append((m.start(4), m.end(4), "value"))

"""Syntax classes of one line of a script, for highlighting, from the language's own scanner.

Classes: ``comment``, ``directive`` (``@rate``), ``speaker`` (``guide:``), ``tag`` (the
brackets and kind of ``[pose:...]``, ``[pause ...]``, ``<...>``, ``</...>``, and a stray
bracket the scanner cannot read), ``name`` (a gesture, style element or preset), ``value``
(options and values: ``x2``, ``flip``, ``hold=500ms``, ``-1``, ``300ms``) and ``escape``
(``\\[``). Every tag and tag-like piece is recognisable without colour too: the editor shows
them bold or underlined (see the theme in :mod:`sgt_tui.app.script_area`).

The line is read by :func:`sgt_tui.editor.tokens.line_tokens` (the language's line rules and
body scanner), so what is highlighted as a tag is what the language reads as one.
"""

from __future__ import annotations

from functools import lru_cache

from sgt_tui.editor.tokens import line_tokens

Span = tuple[int, int, str]  # start column, end column (exclusive), class


@lru_cache(maxsize=8192)
def line_spans(line: str) -> tuple[Span, ...]:
    """Highlight spans of one source line, in column order."""
    tok = line_tokens(line)
    spans: list[Span] = []
    if tok.code_end < len(line):
        spans.append((tok.code_end, len(line), "comment"))
    if tok.directive is not None:
        a, b = tok.directive
        spans.append((a, b, "directive"))
        col = b
        code = line[: tok.code_end]
        while col < len(code):  # the arguments, one value per word
            if code[col].isspace():
                col += 1
                continue
            end = col
            while end < len(code) and not code[end].isspace():
                end += 1
            spans.append((col, end, "value"))
            col = end
        return tuple(sorted(spans))
    if tok.speaker is not None:
        spans.append((*tok.speaker, "speaker"))
    for kind, s, e, payload in tok.items:
        if kind == "escape":
            spans.append((s, e, "escape"))
        elif kind == "tag":
            names, args = payload
            spans += [(s, s + 1, "tag"), (e - 1, e, "tag")]
            for i, (name, at) in enumerate(names):
                spans.append((at, at + len(name), "tag" if i == 0 else "name"))
            spans += [(a, b, "value") for _, _, a, b in args]
        elif kind == "style_open":
            spans += [(s, s + 1, "tag"), (e - 1, e, "tag")]
            for name, value, a, b in payload:
                spans.append((a, a + len(name), "name"))
                if value is not None:
                    spans.append((b - len(value), b, "value"))
        elif kind == "style_close":
            spans += [(s, s + 2, "tag"), (e - 1, e, "tag")]
            if payload:
                at = line.index(payload[0], s + 2)
                spans.append((at, at + len(payload[0]), "name"))
    spans += [(b, b + 1, "tag") for b in tok.bad if line[b] in "[<"]
    return tuple(sorted(spans))

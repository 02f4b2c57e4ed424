"""The reference parser of an utterance body: Lark with the grammar in dsl/sgt.lark.

The grammar is the language's definition. The analyser itself reads every body with the
regular-expression scanner (:mod:`dsl.scan`), which builds the same items about ten times
faster and stops where the grammar fails; tests/test_scan.py checks the two against each
other on random bodies. Lark is imported only by :func:`lark_parser` (the tests, and anyone who
wants the grammar's own parse).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path


def _span_of(children) -> tuple[int, int]:
    first, last = children[0], children[-1]
    start = first.start_pos if hasattr(first, "start_pos") else first[-2]
    end = last.end_pos if hasattr(last, "end_pos") else last[-1]
    return start, end


def _named(children):
    return [c for c in children if getattr(c, "type", None) in ("NAME", "WORD")]


@lru_cache(maxsize=1)
def lark_parser():
    """The LALR parser; it builds the items while parsing (no parse tree)."""
    from lark import Lark, Transformer

    class Build(Transformer):
        def start(self, c):
            return c

        def text(self, c):
            return ("text", c[0].start_pos, c[0].end_pos, str(c[0]))

        def escape(self, c):
            return ("escape", c[0].start_pos, c[0].end_pos, str(c[0]))

        def tag(self, c):
            names = [(str(t), t.start_pos) for t in _named(c)]
            return ("tag", *_span_of(c), (names, [a for a in c if isinstance(a, tuple)]))

        def arg(self, c):
            toks = _named(c)
            return (str(toks[0]), str(toks[1]) if len(toks) > 1 else None, *_span_of(c))

        style_item = arg

        def style_open(self, c):
            return ("style_open", *_span_of(c), [a for a in c if isinstance(a, tuple)])

        def style_close(self, c):
            return ("style_close", *_span_of(c), [str(t) for t in _named(c)])

    return Lark.open(
        str(Path(__file__).with_name("sgt.lark")), parser="lalr", lexer="contextual",
        keep_all_tokens=True, transformer=Build(),
    )

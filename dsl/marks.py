"""Edits of a script's text that a pose editor makes: a ``[pose:NAME]`` mark before a word, and an
``@library`` folder in the header. Each changes only what it adds, in the layout ``sgt fmt``
keeps (:mod:`dsl.fmt`): a script that ``sgt fmt --check`` passes still passes after it.
"""

from __future__ import annotations

import re

from dsl.lines import split_statements
from dsl.parser import analyse

#: Characters that open a word in the text (a quote, a bracket): a mark goes before them.
_OPENERS = "\"'(\u201c\u2018\u00ab\u00bf\u00a1"


class MarkError(ValueError):
    """No word where a mark was asked for; ``str()`` is one line."""


def word_position(source: str, utterance: int, word: int) -> tuple[int, int]:
    """(line, column), 1-based, of word ``word`` (0-based) of utterance ``utterance`` (0-based,
    as the compiled plan numbers them) in ``source`` (its byte-order mark, if any, not counted)."""
    script = analyse(_no_bom(source)[1], gesture_names=None)
    for u in script.utterances:
        if u.index == utterance:
            if not 0 <= word < len(u.words):
                raise MarkError(f"utterance {utterance} has {len(u.words)} words; there is no word {word}")
            where = u.words[word].where
            return where.line, where.col
    raise MarkError(f"the script has no utterance {utterance}")


def insert_mark(source: str, line: int, col: int, name: str) -> str:
    """``source`` with ``[pose:NAME] `` before the word that starts at ``line``:``col`` (1-based;
    before the quote or bracket that opens it, if one does); every other character kept (a
    byte-order mark too: not counted in the columns)."""
    bom, source = _no_bom(source)
    script = analyse(source, gesture_names=None)
    if not any(w.where.line == line and w.where.col == col for u in script.utterances for w in u.words):
        raise MarkError(f"line {line}, column {col}: no word starts there")
    lines = _lines(source)
    text = lines[line - 1]
    at = start = col - 1
    while start > 0 and text[start - 1] in _OPENERS:
        start -= 1
    if start == 0 or text[start - 1] in " \t>]":  # a quote that opens the word, not one inside it (l'amour)
        at = start
    lines[line - 1] = text[:at] + f"[pose:{name}] " + text[at:]
    return bom + "".join(lines)


def add_library(source: str, folder: str) -> str:
    """``source`` with ``@library FOLDER`` in its header: after its last directive before the
    first utterance, else on the line before the first utterance (after leading comments)."""
    bom, source = _no_bom(source)
    statements, _ = split_statements(source)
    first = next((s.line for s in statements if s.kind == "utterance"), None)
    directives = [s for s in statements if s.kind == "directive" and (first is None or s.line < first)]
    ends = _lines(source)
    first_end = re.search(r"\r\n|\r|\n", source)
    line_end = first_end.group(0) if first_end else "\n"
    if ends and not ends[-1].endswith(("\n", "\r")):
        ends[-1] += line_end
    at = directives[-1].line if directives else (first - 1 if first is not None else len(ends))
    ends.insert(at, f"@library {folder}{line_end}")
    return bom + "".join(ends)


def _no_bom(source: str) -> tuple[str, str]:
    """(the byte-order mark or "", the text after it)."""
    bom = "\ufeff" if source.startswith("\ufeff") else ""
    return bom, source[len(bom):]


def _lines(source: str) -> list[str]:
    """The lines of ``source`` with their ends, as the language splits them (CRLF, CR, LF)."""
    parts = re.split(r"(\r\n|\r|\n)", source)
    lines = [parts[i] + (parts[i + 1] if i + 1 < len(parts) else "") for i in range(0, len(parts), 2)]
    return lines if lines[-1] else lines[:-1]

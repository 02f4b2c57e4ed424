"""SSML (what cloud and browser speech engines read) as a script: ``<mark name=.../>`` becomes
a pose or look mark (:func:`dsl.markup.mark_for`), ``<break>`` a pause, the text is spoken as
it is. ``sgt import FILE.ssml`` and ``sgt serve``'s ``ssml`` requests read it."""

from __future__ import annotations

import re

from dsl.markup import MarkMap, Problem, Utterance, mark_for
from dsl.xmlread import Element

#: ``<break strength=...>`` as a pause (SSML leaves the lengths to the engine; these are sgt's).
BREAK_STRENGTHS = {"none": 0, "x-weak": 100, "weak": 200, "medium": 400, "strong": 700, "x-strong": 1000}
#: Elements whose text is spoken and whose own settings sgt does not take (a warning says so).
_TEXT_ONLY = ("prosody", "emphasis", "say-as", "voice", "lang", "phoneme", "audio", "w", "token")
#: Elements that only hold text.
_CONTAINERS = ("speak", "p", "s", "paragraph", "sentence")
_TIME = re.compile(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*(ms|s)\s*")


def ssml_utterance(root: Element, file: str, marks: MarkMap, library) -> tuple[Utterance, list[Problem]]:
    """One utterance of the ``<speak>`` document ``root``, and the problems."""
    problems: list[Problem] = []
    if root.tag != "speak":
        problems.append(Problem(file, root.line, root.col, f"<{root.tag}> is not SSML's <speak>: write the text inside <speak>"))
    pieces: list = []
    _walk(root, pieces, file, marks, library, problems)
    return Utterance(None, pieces, file, root.line, root.col), problems


def _walk(e: Element, pieces: list, file: str, marks: MarkMap, library, problems: list[Problem]) -> None:
    for c in e.children:
        if isinstance(c, str):
            pieces.append(("text", c))
            continue
        if c.tag == "mark":
            name = c.attrs.get("name", "")
            mark = mark_for(name, marks, library)
            if mark is None:
                problems.append(Problem(file, c.line, c.col, f"<mark name='{name}'> names no sgt gesture "
                                                             "(sgt library list shows them): map it with --map FILE"))
            else:
                pieces.append(("mark", mark))
        elif c.tag == "break":
            ms = _break_ms(c, file, problems)
            if ms:
                pieces.append(("mark", f"[pause {ms}ms]"))
        elif c.tag == "sub":
            pieces.append(("text", f" {c.attrs.get('alias', c.text())} "))
        elif c.tag in _CONTAINERS:
            pieces.append(("text", " "))
            _walk(c, pieces, file, marks, library, problems)
            pieces.append(("text", " "))
        elif c.tag in _TEXT_ONLY:
            problems.append(Problem(file, c.line, c.col, f"<{c.tag}> is not kept, its text is "
                                                         "(sgt's @voice, @rate and @pitch set the voice)", warning=True))
            _walk(c, pieces, file, marks, library, problems)
        else:
            problems.append(Problem(file, c.line, c.col, f"<{c.tag}> is not SSML that sgt reads "
                                                         "(speak, p, s, mark, break, sub and the text of prosody, emphasis, "
                                                         "say-as, voice, lang, phoneme, audio)"))


def _break_ms(e: Element, file: str, problems: list[Problem]) -> int:
    """A break's length in whole milliseconds (0: none), at most 10 s as ``[pause]`` allows."""
    if "time" in e.attrs:
        m = _TIME.fullmatch(e.attrs["time"])
        if m is None:
            problems.append(Problem(file, e.line, e.col, f"<break time='{e.attrs['time']}'>: write a time as 300ms or 1.2s"))
            return 0
        ms = round(float(m.group(1)) * (1 if m.group(2) == "ms" else 1000))
    else:
        strength = e.attrs.get("strength", "medium")
        if strength not in BREAK_STRENGTHS:
            problems.append(Problem(file, e.line, e.col, f"<break strength='{strength}'>: one of {', '.join(BREAK_STRENGTHS)}"))
            return 0
        ms = BREAK_STRENGTHS[strength]
    if ms > 10_000:
        problems.append(Problem(file, e.line, e.col, f"<break> of {ms} ms: a pause is at most 10 s; split it"))
        return 0
    return ms

"""Checks of a script's speakers as a whole: the names per-speaker directives give
(``@voice NAME: ...``, ``@rate``, ``@pitch``) against the speakers of its lines, speaker
names that differ only in case, and the speakers look marks name (``[look:NAME]``).

These look at every line at once, so the analysis runs them after the last statement
(:func:`dsl.parser.analyse`). The editor, which analyses a script in chunks
(:mod:`sgt_tui.editor.analysis`), runs :func:`speaker_diagnostics` on the whole text, and
analyses a chunk that has a look mark among all the script's speakers, so that
:func:`look_targets` judges it as in the whole file.
"""

from __future__ import annotations

from core import rules
from core.diagnostics import Diagnostic, Fix, Related, TextEdit
from core.face import LOOK_DIRECTIONS
from dsl.script import Header, Span, Utterance

#: The codes :func:`speaker_diagnostics` reports (the editor recomputes them on the whole text).
CODES = frozenset({rules.UNKNOWN_SPEAKER.code, rules.SPEAKER_CASE.code})


def speaker_diagnostics(file: str, header: Header, speakers: list[tuple[str, Span]]) -> list[Diagnostic]:
    """Warnings about the speakers of a script that has utterances (a script without any is
    not checked: its lines are still to be written): ``speakers`` are (name, where the name is)
    of its lines that have one, in order; ``header.speaker_refs`` the names its directives give.

    - a speaker spelt like an earlier one but for case (:data:`core.rules.SPEAKER_CASE`), once
      per spelling, at its first line, with one fix that rewrites all its lines;
    - a per-speaker directive naming no line's speaker (:data:`core.rules.UNKNOWN_SPEAKER`),
      with a fix per close speaker.
    """
    out: list[Diagnostic] = []
    places: dict[str, list[Span]] = {}
    for name, where in speakers:
        places.setdefault(name, []).append(where)
    first_of: dict[str, str] = {}  # folded name -> the first spelling
    for name, spans in places.items():
        first = first_of.setdefault(name.casefold(), name)
        if first == name:
            continue
        w, f = spans[0], places[first][0]
        edits = tuple(TextEdit(s.line, s.col, s.length, first) for s in spans)
        lines = f"its {len(spans)} lines" if len(spans) > 1 else "its line"
        out.append(rules.SPEAKER_CASE.at(
            file, w.line, w.col, w.length, name=name, first=first,
            related=(Related(f"'{first}' first speaks here", file, f.line, f.col, f.length),),
            fixes=(Fix(f"write '{first}' on {lines}", edits),)))
    for name, w, directive in header.speaker_refs:
        if name in places:
            continue
        # (a spelling that differs from an earlier one only in case is not suggested: it is warned about)
        hint, fixes = rules.did_you_mean(name, list(dict.fromkeys(first_of.values())), w.line, w.col, w.length)
        related: tuple = ()
        if fixes:
            best = fixes[0].edits[0].text
            s = places[best][0]
            related = (Related(f"'{best}' first speaks here", file, s.line, s.col, s.length),)
            if best.casefold() == name.casefold():
                hint = f"{hint} (speaker names are case-sensitive)"
        out.append(rules.UNKNOWN_SPEAKER.at(file, w.line, w.col, w.length, directive=directive, name=name,
                                            related=related, fixes=fixes, **({"hint": hint} if hint else {})))
    return out


def look_targets(file: str, utterances: list[Utterance]) -> list[Diagnostic]:
    """Warnings about ``[look:NAME]`` marks of ``utterances`` (every one of the script) whose
    NAME is the speaker of its own line (:data:`core.rules.LOOK_AT_SELF`) or no speaker of the
    script and no direction (:data:`core.rules.UNKNOWN_LOOK_TARGET`, a fix per close name);
    those marks are dropped from their utterances: the eyes ignore them."""
    out: list[Diagnostic] = []
    speakers = list(dict.fromkeys(u.speaker for u in utterances if u.speaker))
    known = set(speakers) | set(LOOK_DIRECTIONS)
    for u in utterances:
        if not u.looks:
            continue
        keep = []
        for mark in u.looks:
            t = mark.target_where
            if mark.target == u.speaker:
                others = ", ".join([s for s in speakers if s != u.speaker][:3] + ["left", "right"])
                out.append(rules.LOOK_AT_SELF.at(file, t.line, t.col, t.length, name=mark.target, others=others))
                continue
            if mark.target in known:
                keep.append(mark)
                continue
            hint, fixes = rules.did_you_mean(mark.target, speakers + list(LOOK_DIRECTIONS), t.line, t.col, t.length)
            out.append(rules.UNKNOWN_LOOK_TARGET.at(file, t.line, t.col, t.length, name=mark.target,
                                                    fixes=fixes, **({"hint": hint} if hint else {})))
        u.looks = keep
    return out

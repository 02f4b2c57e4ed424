"""Live diagnostics and estimated plans for the editor, re-analysing only what changed.

The analyser and compiler of :mod:`dsl` see a whole file; on a 500-line script that takes
longer than a keystroke should. This module cuts the script into *chunks*, each analysed by
the real front end (:func:`dsl.compiler.compile_file` with estimated timing) and cached by its
text and the context it is analysed in:

- chunk 0: the header and the first utterance, analysed as they are;
- chunk k: the lines after utterance k-1 up to the end of utterance k (directives such as
  ``@audio`` belong to the utterance they precede), analysed as *header + stand-in utterances
  + the chunk*, so that header settings, presets, ``@library`` gestures and the "must be in
  the header" rule apply exactly as in the whole file (the header's ``@audio``, which the
  first utterance speaks, is left out: it is chunk 0's);
- the tail: lines after the last utterance (a dangling ``@audio``, say), analysed the same way.

The stand-ins are one utterance without a speaker, or, for a chunk that has a look mark, one
line for each speaker of the script in order: whether ``[look:NAME]`` names a speaker (and
which names a misspelt one could mean) depends on every line, so such a chunk is analysed
among all the script's speakers, and analysed again when they change (chunk 0 gets them after
its utterance). Diagnostics of the stand-ins and the repeated header are dropped; the rest are
moved to their real lines. What depends on the whole script is computed on the whole script
instead, exactly as the compiler does on the whole file: the speakers
(:func:`dsl.speakers.speaker_diagnostics`: a directive naming no line's speaker, names that
differ only in case); and, when no chunk has an error, the performance's length against the
limits (:func:`dsl.limits.too_long`, on the chunks' declared plans laid out together; a
script over them gets that error and no timing warning) and the interruptions that the
performance clock had to start later (:func:`dsl.compiler.interruption_diagnostics`, on the
chunks' plans laid out together). A script with errors gets no timing warning (overlapping
pose controls), as ``sgt check`` plans nothing then; the estimated plan of an utterance
without errors of its own is still kept, so the timeline keeps working while the user types.
A keystroke inside one utterance re-analyses one chunk. The result equals the whole-file
analysis: tests/test_parity.py compares them, and the language server's, on every script of
the tests and on generated ones.
"""

from __future__ import annotations

import dataclasses
import hashlib
import re
from bisect import bisect_right
from dataclasses import dataclass, field
from pathlib import Path

from core import rules
from core.diagnostics import ERROR, WARNING, Diagnostic, sort_key
from core.skeleton import FPS
from dsl.compiler import INTERRUPTION_CODES, compile_file, interruption_diagnostics
from dsl.limits import passing, too_long
from dsl.lines import split_lines, split_statements
from dsl.parser import analyse
from dsl.plan import Plan
from dsl.script import Script, Span
from dsl.speakers import CODES as SPEAKER_CODES
from dsl.speakers import speaker_diagnostics
from library import load_library

STAND_IN = "x"  # the stand-in utterance put before a chunk (its diagnostics are dropped)
#: What the compiler finds only by planning a script that has no error and fits the limits:
#: dropped from the chunks' diagnostics when the whole script has an error or is too long.
PLANNED_CODES = frozenset({rules.OVERLAP.code})
#: About the whole script: never taken from a chunk, computed by :meth:`Analyser.run` on it.
WHOLE_CODES = SPEAKER_CODES | INTERRUPTION_CODES | {rules.PERFORMANCE_TOO_LONG.code}
_DIRECTIVE_NAME = re.compile(r"@([A-Za-z_][A-Za-z0-9_\-]*)")


@dataclass
class UtteranceInfo:
    """One utterance of the script as the editor sees it (lines are 1-based, real)."""

    index: int
    line: int  # first line of the statement
    last_line: int
    chunk_line: int  # first line of its chunk (directives before it belong to it)
    speaker: str | None
    key: str  # identifies its text and header: generated motion for the same key is current
    utterance: object | None = None  # dsl.script.Utterance, positions moved by line_shift
    plan: object | None = None  # dsl.plan.UtterancePlan with estimated timing, or None on errors
    line_shift: int = 0  # add to the line numbers inside ``utterance`` and ``plan``
    errors: int = 0

    def word_spans(self) -> list[tuple[int, int, int]]:
        """(row, start col, end col), 0-based, of each spoken word in the file."""
        if self.utterance is None:
            return []
        return [(w.where.line + self.line_shift - 1, w.where.col - 1, w.where.col - 1 + w.where.length)
                for w in self.utterance.words]


@dataclass
class Analysis:
    diagnostics: list[Diagnostic]
    utterances: list[UtteranceInfo]
    header: object | None = None  # dsl.script.Header
    library: object | None = None  # library.Library
    by_line: dict[int, list[Diagnostic]] = field(default_factory=dict)

    @property
    def errors(self) -> int:
        return sum(d.severity == ERROR for d in self.diagnostics)

    @property
    def warnings(self) -> int:
        return sum(d.severity == WARNING for d in self.diagnostics)

    def utterance_at(self, line: int) -> UtteranceInfo | None:
        """The utterance a (1-based) line belongs to: its own statement or chunk, else the first."""
        if not self.utterances:
            return None
        starts = [u.chunk_line if u.index else 1 for u in self.utterances]
        i = max(0, bisect_right(starts, line) - 1)
        return self.utterances[i]

    def at(self, line: int, col: int | None = None) -> list[Diagnostic]:
        """Diagnostics on a line (1-based), those covering column ``col`` (1-based) first."""
        found = self.by_line.get(line, [])
        if col is None:
            return list(found)
        inside = [d for d in found if d.col <= col < d.col + max(1, d.length)]
        return inside + [d for d in found if d not in inside]


@dataclass
class _Chunk:
    diagnostics: list[Diagnostic]  # at canonical lines
    utterance: object | None
    plan: object | None
    header: object | None
    canonical_start: int  # 1-based line of the chunk's first line in the analysed source
    extra: list[Diagnostic] = field(default_factory=list)  # not about this script (library specs)
    declared: object | None = None  # dsl.plan.UtterancePlan on its declared timing (dsl.limits)


def _moved(d: Diagnostic, shift: int, start: int, first: tuple[int, int] | None = None) -> Diagnostic:
    """A chunk's diagnostic at its real line. Its span, and the related spans and fix edits in
    the chunk (canonical lines from ``start`` on), move by ``shift`` lines; places above the
    chunk are the header's, already real, or the first stand-in's, which is on the first
    utterance's line: ``first`` (that line, the length of the first utterance's first line)
    gives such a place the first utterance's span ("the header ends before it"). Places in
    other files (a library spec) stay."""
    if not shift and first is None:
        return d

    def move(line: int) -> int:
        return line + shift if line >= start else line

    def place(r):
        if first is not None and r.line == first[0] and r.col == 1:
            return dataclasses.replace(r, length=first[1])
        return dataclasses.replace(r, line=move(r.line))

    related = tuple(place(r) if r.file == d.file and r.line else r for r in d.related)
    fixes = tuple(dataclasses.replace(f, edits=tuple(dataclasses.replace(e, line=move(e.line)) for e in f.edits))
                  for f in d.fixes)
    return dataclasses.replace(d, line=d.line + shift, related=related, fixes=fixes)


def _digest(*parts: str) -> str:
    h = hashlib.sha1()
    for p in parts:
        h.update(p.encode("utf-8", "surrogatepass"))
        h.update(b"\0")
    return h.hexdigest()


class Stopped(Exception):
    """An analysis given up half-way (:meth:`Analyser.run`'s ``stop`` said so)."""


class Analyser:
    """Analyses successive versions of one script, reusing the chunks that did not change."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        self._chunks: dict[tuple, _Chunk] = {}
        self._headers: dict[str, object] = {}
        self.chunks_analysed = 0  # how many chunks the last run had to analyse (for tests)
        self.progress = (0, 0)  # (utterances done, utterances) of the run in progress
        # Two runs may overlap (one on a worker thread, one for an action). A run adds each chunk
        # it analyses to the cache at once (so a run that is stopped keeps its work for the next:
        # a long script's first analysis is never started over) and replaces the cache whole at
        # its end with the chunks it used; a dict is never seen half-updated.

    def run(self, text: str, stop=None) -> Analysis:
        """The analysis of ``text``. ``stop``: called between chunks; when it returns True the
        run raises :class:`Stopped` (the chunks analysed so far stay cached)."""
        lines = text.split("\n")
        statements, _ = split_statements(text)
        utts = [s for s in statements if s.kind == "utterance"]
        prefix_end = utts[0].line - 1 if utts else len(lines)
        prefix = lines[:prefix_end]
        prefix_text = "\n".join(prefix)
        header = self._header(prefix_text)
        lib = load_library(extra_dirs=header.library_dirs)
        lib_key = _digest(*lib.names(), *(str(p) for p in lib.problems), *(str(f) for _, f in lib.folders))
        header_key = _digest(*(s.text for s in statements if s.kind == "directive" and s.line <= prefix_end))
        # The header as the later chunks see it: without its @audio, which the first utterance speaks.
        later = list(prefix)
        for n in header_audio(statements):
            later[n - 1] = ""
        later_text = "\n".join(later)
        speakers = tuple(dict.fromkeys(s.speaker for s in utts if s.speaker))
        # the stand-in of a later chunk is on the first utterance's line: places there are the first utterance's
        first = (prefix_end + 1, max(1, len(utts[0].text.split("\n", 1)[0]))) if utts else None

        used: dict[tuple, _Chunk] = {}
        cached = self._chunks
        analysed = [0]

        def chunk(kind: str, body: list[str]) -> tuple[_Chunk, tuple]:
            body_text = "\n".join(body)
            # a look mark's target is judged among the script's speakers: such a chunk is analysed among them
            context = speakers if kind != "tail" and speakers and "look" in body_text else ()
            key = (kind, later_text if kind != "first" else "", body_text, lib_key, context)
            hit = cached.get(key) or used.get(key)
            if hit is None:
                if stop is not None and stop():
                    raise Stopped()
                hit = cached[key] = self._analyse(kind, later, body, lib, context)
                analysed[0] += 1
            used[key] = hit
            return hit, context

        diags: list[Diagnostic] = []
        infos: list[UtteranceInfo] = []
        declared: list = []  # each utterance's plan on its declared timing (the limits are checked on them)
        script_header = header
        if not utts:
            c, _ = chunk("first", lines)
            diags += c.diagnostics + c.extra
            script_header = c.header or header
        else:
            prev_end = 0  # 0-based index of the first line after the previous utterance
            pending: list[str] = []  # directives between the previous utterance and this one
            owners = iter(statements)
            for k, stmt in enumerate(utts):
                self.progress = (k, len(utts))
                for s in owners:
                    if s is stmt:
                        break
                    if s.line > prefix_end:
                        pending.append(s.text)
                body = lines[: stmt.last_line] if k == 0 else lines[prev_end : stmt.last_line]
                c, context = chunk("first" if k == 0 else "next", body)
                real_start = 1 if k == 0 else prev_end + 1
                shift = real_start - c.canonical_start
                moved = [_moved(d, shift, c.canonical_start, first if k else None) for d in c.diagnostics]
                diags += moved
                if k == 0:
                    diags += c.extra
                    script_header = c.header or header
                own, pending = pending + [stmt.text], []
                infos.append(UtteranceInfo(
                    index=k, line=stmt.line, last_line=stmt.last_line, chunk_line=real_start,
                    speaker=stmt.speaker, key=_digest(header_key, *own, *context), utterance=c.utterance,
                    plan=c.plan, line_shift=shift, errors=sum(d.is_error for d in moved),
                ))
                declared.append(c.declared)
                prev_end = stmt.last_line
            tail = lines[prev_end:]
            if any(s.line > prev_end for s in statements):
                c, _ = chunk("tail", tail)
                shift = prev_end + 1 - c.canonical_start
                diags += [_moved(d, shift, c.canonical_start, first) for d in c.diagnostics]
        if utts:  # what depends on the whole script (the chunks' own are dropped: see _analyse)
            diags += speaker_diagnostics(str(self.path), header, [(s.speaker, Span(s.line, 1, len(s.speaker)))
                                                                  for s in utts if s.speaker])
            # as the compiler: a script with errors is not planned, one over the limits is not planned further
            over = None if any(d.is_error for d in diags) else self._too_long(infos, declared, script_header)
            if over is not None or any(d.is_error for d in diags):
                diags = [d for d in diags if d.code not in PLANNED_CODES] + ([over] if over else [])
            elif all(i.plan is not None for i in infos) and any(i.plan.gap < 0 for i in infos):
                diags += self._interruptions(infos, text)
        self._chunks, self.chunks_analysed = used, analysed[0]
        self.progress = (len(utts), len(utts))
        diags.sort(key=sort_key)
        by_line: dict[int, list[Diagnostic]] = {}
        for d in diags:
            if d.file == str(self.path):
                by_line.setdefault(d.line, []).append(d)
        return Analysis(diags, infos, script_header, lib, by_line)

    def _too_long(self, infos: list[UtteranceInfo], declared: list, header) -> Diagnostic | None:
        """The error of a performance longer than the limits allow (:func:`dsl.limits.too_long`),
        from the chunks' declared plans laid out together (on copies: a chunk's plans are cached
        as its chunk laid them out), at the place its utterance passes them."""
        if any(p is None for p in declared):
            return None
        plans = []
        for n, p in enumerate(declared):  # shallow copies, cheaply: a keystroke lays them all out
            p_copy = object.__new__(type(p))
            p_copy.__dict__.update(p.__dict__)
            p_copy.index = n
            plans.append(p_copy)
        plan = Plan(str(self.path), FPS, 0, plans)
        n = passing(plan)
        if n is None:
            return None
        info = infos[n]  # the utterance that passes them: too_long places its error in it
        d = too_long(Script(str(self.path), "", header, [dataclasses.replace(info.utterance, index=n)], []), plan)
        return _moved(d, info.line_shift, info.chunk_line - info.line_shift) if d is not None else None

    def _interruptions(self, infos: list[UtteranceInfo], text: str) -> list[Diagnostic]:
        """The interruptions of the whole performance, from the chunks' estimated plans laid out
        together (on copies: a chunk's plan is cached as its chunk laid it out)."""
        plan = Plan(str(self.path), FPS, 0, [dataclasses.replace(i.plan) for i in infos])
        if not plan.moved:
            return []
        return interruption_diagnostics(str(self.path), plan, [(i.utterance, i.line_shift) for i in infos],
                                        split_lines(text), True)

    def _header(self, prefix_text: str):
        hit = self._headers.get(prefix_text)
        if hit is None:
            hit = analyse(prefix_text, str(self.path), gesture_names=None, base_dir=self.path.parent).header
            self._headers = {prefix_text: hit}
        return hit

    def _analyse(self, kind: str, prefix: list[str], body: list[str], lib, speakers: tuple) -> _Chunk:
        """Compile one chunk in its context (see the module's docstring): the stand-ins are a
        line of each of ``speakers`` (empty: one line without a speaker), after chunk 0's
        utterance, before a later chunk."""
        stand_ins = [f"{name}: {STAND_IN}" for name in speakers] or [STAND_IN]
        if kind == "first":
            source_lines, start = body + (stand_ins if speakers else []), 1
        else:
            source_lines, start = prefix + stand_ins + body, len(prefix) + len(stand_ins) + 1
        end = start + len(body) - 1
        result = compile_file(self.path, timing="estimate", library=lib, source="\n".join(source_lines))
        mine = str(self.path)
        own = [d for d in result.diagnostics
               if d.file == mine and (d.line >= start or kind == "first") and d.line <= end and d.code not in WHOLE_CODES]
        extra = [d for d in result.diagnostics if d.file != mine]
        script = result.script
        utt = next((u for u in script.utterances if start <= u.line <= end), None) if kind != "tail" else None
        plan = declared = None
        if utt is not None:
            if result.plan is not None:
                plan = next((u for u in result.plan.utterances if u.index == utt.index), None)
            declared = next((u for u in result.declared if u.index == utt.index), None)
        return _Chunk(own, utt, plan, script.header, start, extra, declared)


def header_audio(statements) -> list[int]:
    """The lines (1-based) of the ``@audio`` directives before the first utterance of a script's
    statements (:func:`dsl.lines.split_statements`): recordings the first utterance speaks, not
    the header's (an utterance analysed after the header without the first must not get them)."""
    out = []
    for s in statements:
        if s.kind == "utterance":
            break
        m = _DIRECTIVE_NAME.match(s.text)
        if m and m.group(1) == "audio":
            out.append(s.line)
    return out


def goto_line(answer: str, analysis: Analysis | None, line_count: int) -> int:
    """The 1-based line that ``answer`` names: ``12`` is line 12, ``u3`` the first line of
    utterance 3 (counting from 1, as the status line; ``analysis`` None: not known yet).
    Raises ValueError with what is wrong."""
    text = answer.strip().lower()
    utterance = text.startswith("u")
    number = text[1:].strip() if utterance else text
    if not number.isdigit() or int(number) < 1:
        raise ValueError(f"'{answer}' is not a line number (12) or an utterance (u3)")
    n = int(number)
    if utterance:
        if analysis is None:
            raise ValueError("the script is still being analysed: its utterances are not known yet (a line number works)")
        if n > len(analysis.utterances):
            raise ValueError(f"there is no utterance {n}: the script has {len(analysis.utterances)}")
        return analysis.utterances[n - 1].line
    if n > line_count:
        raise ValueError(f"there is no line {n}: the script has {line_count} lines")
    return n

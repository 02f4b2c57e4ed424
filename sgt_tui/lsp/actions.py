"""Diagnostics as the protocol carries them, their fixes as code actions, and formatting.

Every diagnostic is the analysis's (:mod:`core.diagnostics`): its code links to the page of
``sgt explain``, its related places and hint come along, and each of its fixes (did you mean,
add a unit, close a span) is a quick fix. Two actions are the server's own, both checked by
the analysis before they are offered: re-timing a gesture to x2 or x3 where a stroke misses
its word (SGT401: offered only when the warning then goes away), and closing an unclosed tag
(SGT104).
"""

from __future__ import annotations

import re
from bisect import bisect_left
from collections import Counter
from pathlib import Path

from lsprotocol import types as lsp

from core import rules
from core.diagnostics import ERROR, WARNING, Diagnostic, sort_key
from dsl.compiler import compile_text
from dsl.fmt import format_source
from dsl.lines import split_statements
from dsl.speech.recording import timings_path
from sgt_tui.editor.analysis import header_audio
from sgt_tui.editor.tokens import line_tokens
from sgt_tui.lsp import knowledge
from sgt_tui.lsp.documents import Document, uri_of

SOURCE = "sgt"
#: The protocol's diagnostic (sgt's own, core.diagnostics.Diagnostic, is built only by its rules).
_ProtocolDiagnostic = lsp.Diagnostic
_SEVERITY = {ERROR: lsp.DiagnosticSeverity.Error, WARNING: lsp.DiagnosticSeverity.Warning}
#: What an unclosed tag could have been, longest first: its closer goes after the match.
_TAG_SO_FAR = (
    (re.compile(r"\[[ \t]*pose[ \t]*:[ \t]*[A-Za-z_][\w\-]*(?:[ \t]+(?:x[123]|flip|hold=[\d.]+m?s))*"), "]"),
    (re.compile(r"\[[ \t]*pause[ \t]+[\d.]+m?s"), "]"),
    (re.compile(r"</[ \t]*[A-Za-z_][\w\-]*"), ">"),
    (re.compile(r"<(?:[ \t]*[A-Za-z_][\w\-]*(?:[ \t]*:[ \t]*[+\-]?[\d.]+)?)+"), ">"),
)


def to_lsp(doc: Document, d: Diagnostic) -> lsp.Diagnostic:
    page = knowledge.explanation_page(d.code) if d.code else None
    related = [lsp.DiagnosticRelatedInformation(
        lsp.Location(doc.uri if r.file == d.file else uri_of(r.file), doc.span(r.line, r.col, r.length)
                     if r.file == d.file else _plain_span(r.line, r.col, r.length)), r.message) for r in d.related]
    rng = doc.span(d.line, d.col, d.length) if d.file == str(doc.path) else _plain_span(d.line, d.col, d.length)
    return _ProtocolDiagnostic(
        rng, d.message + (f"\nhint: {d.hint}" if d.hint else ""),
        severity=_SEVERITY.get(d.severity, lsp.DiagnosticSeverity.Information), code=d.code or None, source=SOURCE,
        code_description=lsp.CodeDescription(uri_of(page)) if page is not None else None,
        related_information=related or None, data={"name": d.name})


def _plain_span(line: int, col: int, length: int) -> lsp.Range:
    """A span in a file the server does not hold (a gesture spec): characters as units."""
    row, start = max(line - 1, 0), max(col - 1, 0)
    return lsp.Range(lsp.Position(row, start), lsp.Position(row, start + max(length, 0)))


def published(doc: Document) -> dict[str, list[lsp.Diagnostic]]:
    """The diagnostics to publish, by URI: the script's, and those of other files its analysis
    read (a malformed gesture spec). A recording the aligner failed on is reported on its
    ``@audio`` line (:mod:`sgt_tui.lsp.aligning`)."""
    out: dict[str, list[lsp.Diagnostic]] = {doc.uri: []}
    analysis = doc.analysis()
    failed = [rules.SPEECH.at(str(doc.path), r.line, r.col, r.length, detail=why) for r, why in doc.failed]
    for d in sorted(analysis.diagnostics + failed, key=sort_key):
        uri = doc.uri if d.file == str(doc.path) else uri_of(d.file)
        out.setdefault(uri, []).append(to_lsp(doc, d))
    return out


# -- code actions -----------------------------------------------------------------------------

def _touches(d: Diagnostic, rng: lsp.Range, doc: Document) -> bool:
    r = doc.span(d.line, d.col, d.length)
    return (r.start.line, r.start.character) <= (rng.end.line, rng.end.character) and \
        (rng.start.line, rng.start.character) <= (r.end.line, r.end.character)


def code_actions(doc: Document, rng: lsp.Range) -> list[lsp.CodeAction]:
    out: list[lsp.CodeAction] = []
    mine = str(doc.path)
    for d in doc.analysis().diagnostics:
        if d.file != mine or not d.line or not _touches(d, rng, doc):
            continue
        wire = to_lsp(doc, d)
        for n, fix in enumerate(d.fixes):
            edits = [lsp.TextEdit(doc.span(e.line, e.col, e.length), e.text) for e in fix.edits]
            out.append(lsp.CodeAction(fix.title, kind=lsp.CodeActionKind.QuickFix, diagnostics=[wire],
                                      edit=lsp.WorkspaceEdit(changes={doc.uri: edits}), is_preferred=n == 0 and len(d.fixes) == 1))
        if d.code == rules.OVERLAP.code:
            out += _retime(doc, d, wire)
        elif d.code == rules.UNCLOSED.code:
            out += _close(doc, d, wire)
        elif d.code == rules.RECORDING_MISMATCH.code:
            out += _use_aligner_times(doc, d, wire)
    return out


#: The command that writes the aligner's times of a recording and names them on its directive.
WRITE_TIMINGS = "sgt.writeTimings"


def aligner_times(doc: Document, line: int):
    """For the utterance on (1-based) ``line`` spoken from a recording without ``timings=``:
    (the utterance, the timings file ``sgt align`` writes for it, the edit that names that file
    on the ``@audio`` directive); None for any other line."""
    info = doc.analysis().utterance_at(line)
    u = info.utterance if info is not None else None
    if u is None or u.audio is None or u.audio.timings is not None:
        return None
    w = u.audio.where
    row = w.line + info.line_shift
    written = doc.line(row - 1)[w.col - 1: w.col - 1 + w.length]
    quote = written[0] if written[:1] in ("\"", "'") else ""
    name = Path(written.strip("\"'"))
    named = str(timings_path(name))  # beside the recording, as the script names it
    target = timings_path(u.audio.path)
    return u, target, lsp.TextEdit(doc.span(row, w.col + w.length, 0), f" timings={quote}{named}{quote}")


def _use_aligner_times(doc: Document, d: Diagnostic, wire: lsp.Diagnostic) -> list[lsp.CodeAction]:
    """For a recording the check rejects (SGT407): write the times the aligner found to a
    timings file (``sgt align``'s) and name it on the directive, or name the one that exists."""
    found = aligner_times(doc, d.line)
    if found is None:
        return []
    _, target, edit = found
    if target.exists():
        return [lsp.CodeAction(f"time the words by {target.name}, which exists (not the aligner)",
                               kind=lsp.CodeActionKind.QuickFix, diagnostics=[wire],
                               edit=lsp.WorkspaceEdit(changes={doc.uri: [edit]}))]
    title = f"write the aligner's word times to {target.name} and time the words by it (review it)"
    return [lsp.CodeAction(title, kind=lsp.CodeActionKind.QuickFix, diagnostics=[wire],
                           command=lsp.Command(title, WRITE_TIMINGS, arguments=[doc.uri, d.line]))]


def _close(doc: Document, d: Diagnostic, wire: lsp.Diagnostic) -> list[lsp.CodeAction]:
    line = doc.line(d.line - 1)
    for pattern, closer in _TAG_SO_FAR:
        m = pattern.match(line, d.col - 1)
        if m:
            edit = lsp.TextEdit(doc.range(d.line - 1, m.end(), m.end()), closer)
            return [lsp.CodeAction(f"close the tag: add '{closer}'", kind=lsp.CodeActionKind.QuickFix, diagnostics=[wire],
                                   edit=lsp.WorkspaceEdit(changes={doc.uri: [edit]}), is_preferred=True)]
    return []


def _pose_tag(doc: Document, row: int, col: int):
    """(start, end, name, speed, its other options) of the ``[pose:...]`` tag starting at 0-based
    ``row``/``col``; None when there is none."""
    for kind, s, e, payload in line_tokens(doc.line(row)).items:
        names, args = payload if kind == "tag" else ((), ())
        if kind == "tag" and s == col and len(names) == 2 and names[0][0] == "pose":
            speed = max([int(k[1]) for k, v, _, _ in args if k in ("x1", "x2", "x3") and v is None] or [1])
            rest = [k if v is None else f"{k}={v}" for k, v, _, _ in args if k not in ("x1", "x2", "x3")]
            return s, e, names[1][0], speed, rest
    return None


def _retime(doc: Document, d: Diagnostic, wire: lsp.Diagnostic) -> list[lsp.CodeAction]:
    """Actions that play the late gesture, or the one in its way, at x2 or x3: each offered
    only when the analysis of the changed utterance has fewer late strokes."""
    analysis = doc.analysis()
    info = analysis.utterance_at(d.line)
    if info is None:
        return []
    places = [(d.line - 1, d.col - 1)] + [(r.line - 1, r.col - 1) for r in d.related if r.file == d.file]
    late = _pose_tag(doc, *places[0])
    out = []
    before = _late_strokes(doc, info, None)
    for row, col in places:
        tag = _pose_tag(doc, row, col)
        if tag is None or late is None:
            continue
        s, e, name, speed, rest = tag
        for faster in (2, 3):
            if faster <= speed:
                continue
            text = "[" + " ".join([f"pose:{name}", f"x{faster}", *rest]) + "]"
            if _late_strokes(doc, info, (row, s, e, text)) < before:
                why = "its stroke then makes its word" if (row, col) == places[0] else f"'{late[2]}' then makes its word"
                out.append(lsp.CodeAction(f"re-time '{name}' to x{faster} ({why})", kind=lsp.CodeActionKind.QuickFix,
                                          diagnostics=[wire], edit=lsp.WorkspaceEdit(changes={doc.uri: [lsp.TextEdit(doc.range(row, s, e), text)]})))
                break
    return out


def _late_strokes(doc: Document, info, change) -> int:
    """SGT401 warnings of utterance ``info`` after ``change`` (row, start, end, text), analysed
    with the header and that utterance only (the other lines blanked, so places stay)."""
    analysis = doc.analysis()
    lines = list(doc.lines)
    first = analysis.utterances[0].line
    keep = set(range(first - 1)) | set(range(info.chunk_line - 1, info.last_line))
    if info.index:  # the first utterance's recording is not this one's
        keep -= {n - 1 for n in header_audio(split_statements(doc.text)[0])}
    trial = [line if n in keep else "" for n, line in enumerate(lines)]
    if change is not None:
        row, s, e, text = change
        trial[row] = trial[row][:s] + text + trial[row][e:]
    result = compile_text(doc.analysed("\n".join(trial)), doc.path, timing="estimate", library=analysis.library)
    return sum(1 for x in result.diagnostics if x.code == rules.OVERLAP.code and info.line <= x.line <= info.last_line)


# -- formatting -------------------------------------------------------------------------------

#: A stretch of changed lines is matched line by line (the longest common subsequence) when its
#: lines before times its lines after stay under this; a larger one is cut at the lines that
#: occur once on both sides.
SMALL_STRETCH = 10_000
#: How many such line pairs one formatting compares in all, and how many lines it looks at per
#: line of the script: beyond them, what is left is replaced whole, so the time stays about
#: linear whatever the lines repeat.
PAIRS = 250_000
WORK_PER_LINE = 64


def formatting(doc: Document) -> list[lsp.TextEdit]:
    """The edits that make the script ``sgt fmt``'s layout, line by line (so the rest of the
    text, and the cursor on it, stays); raises :class:`dsl.fmt.FormatError`."""
    before = _lines_with_ends(doc.text)
    after = _lines_with_ends(format_source(doc.text, str(doc.path)))
    if not before:
        end = lsp.Position(0, 0)
    elif before[-1].endswith("\n"):
        end = lsp.Position(len(before), 0)
    else:
        end = doc.position(len(before) - 1, len(before[-1]))
    edits = []
    for i1, i2, j1, j2 in _changes(before, after):
        start = lsp.Position(i1, 0) if i1 < len(before) else end
        edits.append(lsp.TextEdit(lsp.Range(start, lsp.Position(i2, 0) if i2 < len(before) else end), "".join(after[j1:j2])))
    return edits


def _lines_with_ends(text: str) -> list[str]:
    return re.findall(r"[^\n]*\n|[^\n]+$", text)


def _changes(a: list[str], b: list[str]) -> list[tuple[int, int, int, int]]:
    """Where lines ``a[i1:i2]`` become ``b[j1:j2]``, in order (the lines between are kept)."""
    out = []
    i = j = 0
    for x, y in _kept(a, b) + [(len(a), len(b))]:
        if x > i or y > j:
            out.append((i, x, j, y))
        i, j = x + 1, y + 1
    return out


def _kept(a: list[str], b: list[str]) -> list[tuple[int, int]]:
    """Pairs (i, j) of lines kept (``a[i] == b[j]``), increasing in both. The first and last
    lines two stretches share are kept; a small stretch (:data:`SMALL_STRETCH`) is matched
    exactly (:func:`_common`), a larger one at the lines that occur once in both (the longest
    run of them in the same order: a patience diff), and the stretches between them the same
    way. (difflib's ``SequenceMatcher(autojunk=False)`` took minutes on 20,000 equal lines.)"""
    kept: list[tuple[int, int]] = []
    budget, pairs = WORK_PER_LINE * (len(a) + len(b) + 1), PAIRS
    todo = [(0, len(a), 0, len(b))]
    while todo:
        alo, ahi, blo, bhi = todo.pop()
        while alo < ahi and blo < bhi and a[alo] == b[blo]:
            kept.append((alo, blo))
            alo, blo = alo + 1, blo + 1
        while alo < ahi and blo < bhi and a[ahi - 1] == b[bhi - 1]:
            ahi, bhi = ahi - 1, bhi - 1
            kept.append((ahi, bhi))
        budget -= (ahi - alo) + (bhi - blo)
        size = (ahi - alo) * (bhi - blo)
        if not size or budget < 0:
            continue
        if size <= SMALL_STRETCH:
            if size <= pairs:
                pairs -= size
                kept += [(alo + i, blo + j) for i, j in _common(a[alo:ahi], b[blo:bhi])]
            continue
        anchors = _anchors(a, b, alo, ahi, blo, bhi)
        kept += anchors
        starts = [(alo, blo)] + [(i + 1, j + 1) for i, j in anchors]
        ends = anchors + [(ahi, bhi)]
        todo += [(i0, i1, j0, j1) for (i0, j0), (i1, j1) in zip(starts, ends) if anchors]
    kept.sort()
    return kept


def _common(a: list[str], b: list[str]) -> list[tuple[int, int]]:
    """A longest common subsequence of ``a`` and ``b`` as pairs (i, j): the fewest lines
    changed (time: ``len(a) * len(b)``)."""
    m = len(b)
    longest = [[0] * (m + 1) for _ in range(len(a) + 1)]  # longest[i][j]: of a[i:] and b[j:]
    for i in range(len(a) - 1, -1, -1):
        row, below, line = longest[i], longest[i + 1], a[i]
        for j in range(m - 1, -1, -1):
            row[j] = below[j + 1] + 1 if line == b[j] else max(below[j], row[j + 1])
    out, i, j = [], 0, 0
    while i < len(a) and j < m:
        if a[i] == b[j]:
            out.append((i, j))
            i, j = i + 1, j + 1
        elif longest[i + 1][j] >= longest[i][j + 1]:
            i += 1
        else:
            j += 1
    return out


def _anchors(a: list[str], b: list[str], alo: int, ahi: int, blo: int, bhi: int) -> list[tuple[int, int]]:
    """The longest increasing run of pairs (i, j) of lines that occur once in ``a[alo:ahi]`` and
    once in ``b[blo:bhi]``."""
    in_a, in_b = Counter(a[alo:ahi]), Counter(b[blo:bhi])
    at_b = {line: j for j, line in enumerate(b[blo:bhi], blo) if in_b[line] == 1}
    pairs = [(i, at_b[line]) for i, line in enumerate(a[alo:ahi], alo) if in_a[line] == 1 and line in at_b]
    # the longest increasing subsequence of the j's (patience sorting), pairs already by i
    tops: list[int] = []  # tops[k]: the smallest j ending a run of k + 1
    ends: list[int] = []  # ends[k]: the index in pairs of that run's last pair
    back = [-1] * len(pairs)
    for n, (_, j) in enumerate(pairs):
        k = bisect_left(tops, j)
        if k == len(tops):
            tops.append(j)
            ends.append(n)
        else:
            tops[k], ends[k] = j, n
        back[n] = ends[k - 1] if k else -1
    run = []
    n = ends[-1] if ends else -1
    while n >= 0:
        run.append(pairs[n])
        n = back[n]
    return run[::-1]

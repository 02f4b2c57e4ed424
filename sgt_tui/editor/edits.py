"""Text edits made by the editor's actions, as plain functions of the document.

Every action writes the language's own text (docs/language.md), so the script stays the one
source of truth, readable in a diff:

- :func:`insert_pose`: ``[pose:NAME x2 flip]`` at the cursor (before the word it is in);
- :func:`apply_style`: ``<speed:-1 space:+0.5>`` ... ``</speed>`` (or ``<happy>`` ...
  ``</happy>``) around the selected words of one utterance;
- :func:`move_pose`: a ``[pose:...]`` token moved before the previous or next word, which is
  what anchors it (a pose control's stroke lands on the next word's onset).

Each returns an :class:`Action`: replacements to make in order (one undo step) and where the
cursor goes, or raises :class:`EditRefused` with a message for the user.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from types import SimpleNamespace

from core.controls import STYLE_LIMIT, STYLE_NAMES
from core.counting import plural
from core.diagnostics import Fix, TextEdit
from dsl.lines import split_statements, strip_comment
from dsl.suggest import suggest
from sgt_tui.editor.document import Document, Location, Replacement
from sgt_tui.editor.tokens import line_tokens, spoken_pieces

_WORD_CHAR = re.compile(r"[^\W_]|['\u2019\-]")


class EditRefused(Exception):
    """The action cannot be done here; the message says why (shown to the user)."""


@dataclass
class Action:
    label: str
    replacements: list[Replacement] = field(default_factory=list)
    cursor: Location | None = None
    selection: tuple[Location, Location] | None = None
    message: str = ""


# -- text of tags ---------------------------------------------------------------------------

def pose_tag(name: str, speed: int = 1, flip: bool = False, hold: float | None = None) -> str:
    """``[pose:NAME x2 flip hold=500ms]``; x1 and no hold are left out."""
    parts = [f"pose:{name}"]
    if speed in (2, 3):
        parts.append(f"x{speed}")
    if flip:
        parts.append("flip")
    if hold:
        parts.append(f"hold={int(round(hold * 1000))}ms" if hold < 1 else f"hold={hold:g}s")
    return "[" + " ".join(parts) + "]"


def _value(v: float) -> str:
    v = max(-STYLE_LIMIT, min(STYLE_LIMIT, round(float(v) * 2) / 2))
    return f"{v:+g}" if v else "0"


def style_tags(values: dict[str, float] | None = None, preset: str | None = None) -> tuple[str, str]:
    """Opening and closing tag for a style span: a preset, values, or a preset with values."""
    items = [preset] if preset else []
    for name in STYLE_NAMES:
        if values and name in values and values[name] is not None:
            items.append(f"{name}:{_value(values[name])}")
    if not items:
        raise EditRefused("choose a preset or at least one style value")
    first = items[0].split(":")[0]
    return "<" + " ".join(items) + ">", f"</{first}>"


# -- where things are -----------------------------------------------------------------------

def _statement_at(doc: Document, row: int):
    """The utterance statement covering 0-based ``row``, or None."""
    statements, _ = split_statements(doc.text)
    for s in statements:
        if s.kind == "utterance" and s.line - 1 <= row <= s.last_line - 1:
            return s
    return None


def _in_tag(line: str, col: int) -> tuple[int, int] | None:
    """(start, end) columns of the ``[...]`` or ``<...>`` tag a cursor at ``col`` is inside, if any."""
    return line_tokens(line).tag_at(col)


def _word_bounds(line: str, col: int) -> tuple[int, int] | None:
    """(start, end) of the word at or touching column ``col``."""
    lo = col
    while lo > 0 and _WORD_CHAR.match(line[lo - 1]):
        lo -= 1
    hi = col
    while hi < len(line) and _WORD_CHAR.match(line[hi]):
        hi += 1
    return (lo, hi) if hi > lo else None


def pose_tokens(doc: Document, first_row: int, last_row: int) -> list[tuple[Location, Location]]:
    """Start and end of every ``[pose:...]`` token on rows first_row..last_row."""
    return [((row, a), (row, b)) for row in range(first_row, last_row + 1) for a, b in line_tokens(doc.lines[row]).poses()]


def _has_word(text: str) -> bool:
    """Whether ``text`` (a piece of utterance bodies) holds a spoken word outside tags."""
    return any(re.search(r"[^\W_]", piece) for line in text.split("\n") for piece in spoken_pieces(line))


# -- actions --------------------------------------------------------------------------------

def insert_pose(doc: Document, cursor: Location, tag: str) -> Action:
    """Insert a pose tag at the cursor: before the word the cursor is in, after a tag it is in."""
    row, col = doc.clamp(cursor)
    line = doc.lines[row]
    code = strip_comment(line)
    if line.startswith("@") or (not code.strip() and line.strip()):
        raise EditRefused("put the cursor in an utterance (not a directive or comment) to insert a gesture")
    if col > len(code):  # in a comment: before it
        col = len(code.rstrip())
    tag_span = _in_tag(line, col)
    if tag_span is not None:
        col = tag_span[1]
    else:
        w = _word_bounds(line, col)
        if w is not None and w[0] < col:
            col = w[0]
    stmt = _statement_at(doc, row)
    if stmt is not None and row == stmt.line - 1 and col < stmt.body_offset:
        col = stmt.body_offset
    before = line[col - 1] if col > 0 else " "
    after = line[col] if col < len(line) else " "
    lead = "" if before in " \t>" else " "
    text = lead + tag + ("" if after in " \t<" else " ")
    end_col = col + len(lead) + len(tag)
    return Action("insert gesture", [Replacement((row, col), (row, col), text)], cursor=(row, end_col),
                  message=f"inserted {tag}")


def _clip_to_words(doc: Document, start: Location, end: Location) -> tuple[Location, Location]:
    (r0, c0), (r1, c1) = sorted((doc.clamp(start), doc.clamp(end)))
    if (r0, c0) == (r1, c1):
        w = _word_bounds(doc.lines[r0], c0)
        if w is None:
            raise EditRefused("select the words to style (or put the cursor in a word)")
        return (r0, w[0]), (r0, w[1])
    t = _in_tag(doc.lines[r0], c0)
    if t is not None and t[0] < c0:
        c0 = t[0]
    w = _word_bounds(doc.lines[r0], c0)
    if w is not None:
        c0 = w[0]
    t = _in_tag(doc.lines[r1], c1)
    if t is not None:
        c1 = t[1]
    w = _word_bounds(doc.lines[r1], c1)
    if w is not None:
        c1 = w[1]
    # trim spaces at both ends
    while (r0, c0) < (r1, c1) and c0 < len(doc.lines[r0]) and doc.lines[r0][c0] in " \t":
        c0 += 1
    while (r0, c0) < (r1, c1) and c1 > 0 and doc.lines[r1][c1 - 1] in " \t":
        c1 -= 1
    return (r0, c0), (r1, c1)


def style_target(doc: Document, start: Location, end: Location) -> tuple[Location, Location]:
    """The words a style span over the selection would cover: whole words of one utterance.

    An empty selection means the word at the cursor. Raises EditRefused."""
    (r0, c0), (r1, c1) = _clip_to_words(doc, start, end)
    stmt = _statement_at(doc, r0)
    if stmt is None or not (stmt.line - 1 <= r1 <= stmt.last_line - 1):
        raise EditRefused("select words inside one utterance: a style span cannot cross utterances")
    if r0 == stmt.line - 1 and c0 < stmt.body_offset:
        c0 = stmt.body_offset
    for r, c in ((r0, c0), (r1, c1)):
        if c > len(strip_comment(doc.lines[r])):
            raise EditRefused("the selection reaches into a comment; select only spoken words")
    if (r0, c0) >= (r1, c1) or not _has_word(doc.get_range((r0, c0), (r1, c1))):
        raise EditRefused("select at least one spoken word to style")
    return (r0, c0), (r1, c1)


def apply_style(doc: Document, start: Location, end: Location, *, values: dict[str, float] | None = None,
                preset: str | None = None) -> Action:
    """Wrap the selected words of one utterance in a style span."""
    open_tag, close_tag = style_tags(values, preset)
    (r0, c0), (r1, c1) = style_target(doc, start, end)
    # closing tag first, so the opening one does not move it
    reps = [Replacement((r1, c1), (r1, c1), close_tag), Replacement((r0, c0), (r0, c0), open_tag)]
    end_col = c1 + len(close_tag) + (len(open_tag) if r0 == r1 else 0)
    return Action("apply style", reps, cursor=(r1, end_col), selection=((r0, c0), (r1, end_col)),
                  message=f"styled with {open_tag}")


def move_pose(doc: Document, cursor: Location, step: int, words: list[tuple[int, int, int]]) -> Action:
    """Move the pose token at (or nearest before) the cursor to the previous (-1) or next (+1) word.

    ``words`` are the (row, start col, end col) of the utterance's spoken words, in order
    (from :meth:`sgt_tui.editor.analysis.UtteranceInfo.word_spans`). The tag goes into the gap
    before its new word, right after the first run of spaces in that gap (so before a ``<style>``
    that opens on the word, never inside it); moving it back therefore restores the text exactly."""
    row, col = doc.clamp(cursor)
    stmt = _statement_at(doc, row)
    if stmt is None:
        raise EditRefused("put the cursor on a [pose:...] control of an utterance to move it")
    tokens = pose_tokens(doc, stmt.line - 1, stmt.last_line - 1)
    if not tokens:
        raise EditRefused("this utterance has no [pose:...] control to move")
    at = (row, col)
    inside = [t for t in tokens if t[0] <= at <= t[1]]
    before = [t for t in tokens if t[1] <= at]
    token = inside[0] if inside else (before[-1] if before else tokens[0])
    if not words:
        raise EditRefused("this utterance has no words to anchor the pose control to")
    t0, t1 = token
    starts = [(r, c) for r, c, _ in words]
    slot = next((i for i, s in enumerate(starts) if s >= t1), len(words))
    target = slot + step
    if target < 0 or target > len(words):
        raise EditRefused("the pose control is already at the " + ("first word" if step < 0 else "end of the utterance"))
    tag = doc.get_range(t0, t1)
    text = doc.text
    a, b = doc.offset(t0), doc.offset(t1)
    # the text without the token and one neighbouring space
    if b < len(text) and text[b] == " ":
        b += 1
    elif a > 0 and text[a - 1] == " ":
        a -= 1
    removed = text[:a] + text[b:]

    def moved(loc: Location) -> int:
        off = doc.offset(loc)
        return off - (b - a) if off >= b else off

    if target < len(words):
        wr, wc, _ = words[target]
        word_at = moved((wr, wc))
        if target:
            pr, _, pe = words[target - 1]
            gap_start = moved((pr, pe))
        else:
            gap_start = moved((stmt.line - 1, stmt.body_offset))
        gap = removed[gap_start:word_at]
        space = re.search(r"\s+", gap)
        ins = gap_start + space.end() if space else word_at
        insert, tag_at = tag + " ", ins
    else:
        ins = moved((words[-1][0], words[-1][2]))
        insert, tag_at = " " + tag, ins + 1
    new_text = removed[:ins] + insert + removed[ins:]
    lo = 0  # the smallest region that changed: one replacement, one undo step
    while lo < min(len(text), len(new_text)) and text[lo] == new_text[lo]:
        lo += 1
    hi_old, hi_new = len(text), len(new_text)
    while hi_old > lo and hi_new > lo and text[hi_old - 1] == new_text[hi_new - 1]:
        hi_old, hi_new = hi_old - 1, hi_new - 1
    crow = new_text.count("\n", 0, tag_at)
    ccol = tag_at - (new_text.rfind("\n", 0, tag_at) + 1)
    where = "previous word" if step < 0 else ("next word" if target < len(words) else "end of the utterance")
    return Action("move pose control", [Replacement(doc.location(lo), doc.location(hi_old), new_text[lo:hi_new])],
                  cursor=(crow, ccol + 1), message=f"moved {tag} to the {where}")


def apply_fix(doc: Document, fix: Fix) -> Action:
    """The edits of a diagnostic's suggested fix (1-based line and column, as the diagnostic's).

    Edits are made from the last to the first, so that none moves another. Raises EditRefused
    when the text no longer has the place the fix was made for."""
    reps = []
    for e in sorted(fix.edits, key=lambda e: (e.line, e.col), reverse=True):
        row, col = e.line - 1, e.col - 1
        if not (0 <= row < len(doc.lines)) or not (0 <= col and col + e.length <= len(doc.lines[row])):
            raise EditRefused(f"cannot apply '{fix.title}': the text changed since it was suggested")
        reps.append(Replacement((row, col), (row, col + e.length), e.text))
    if not reps:
        raise EditRefused(f"'{fix.title}' changes nothing")
    first = min(fix.edits, key=lambda e: (e.line, e.col))
    end = (first.line - 1, first.col - 1 + len(first.text)) if "\n" not in first.text else None
    return Action("quick fix", reps, cursor=end, message=f"fixed: {fix.title}")


def suggest_gestures(doc: Document, info, library, rules) -> Action:
    """The gestures the words of one utterance (an analysis's :class:`UtteranceInfo`) call
    for, inserted where it has no mark (:mod:`dsl.suggest`, the rules of ``sgt suggest``), as
    one undoable action. Raises EditRefused when there is nothing to suggest."""
    if info is None or info.utterance is None or info.errors:
        raise EditRefused("no utterance without errors here: suggestions need one")
    found = suggest(SimpleNamespace(utterances=[info.utterance]), library, rules)
    if not found:
        raise EditRefused("no word of this utterance calls for a gesture where it has room for one")
    fix = Fix("suggested gestures", tuple(TextEdit(s.line + info.line_shift, s.col, 0, f"[pose:{s.gesture}] ")
                                          for s in found))
    action = apply_fix(doc, fix)
    names = ", ".join(f"{s.gesture} on '{s.word}'" for s in found)
    return Action("suggest gestures", action.replacements, cursor=action.cursor,
                  message=f"{plural(len(found), 'gesture')} suggested: {names} (ctrl+z takes them back)")

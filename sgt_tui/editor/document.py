"""The document being edited: its text as lines, and one undo history for every change.

Every change goes through :meth:`Document.replace`, whether it was typed, pasted or made by an
action (inserting a gesture, applying a style, moving a pose control), so undo and redo see
one history. Locations are ``(row, column)``, both 0-based, columns counting characters, as in
the Textual text area; line ends inside the document are always ``"\\n"`` (the file's own line
ends are restored on save by :mod:`sgt_tui.editor.files`).

Typing is grouped so that one undo step takes back a word, not a letter; an action's changes
form one step (:meth:`Document.group`).
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass, field

Location = tuple[int, int]

#: Typed characters further apart than this (seconds) start a new undo step.
TYPING_PAUSE = 2.0
#: Undo steps kept.
MAX_STEPS = 2000


def normalise_newlines(text: str) -> str:
    return text.replace("\r\n", "\n").replace("\r", "\n")


@dataclass(frozen=True)
class Change:
    """One replacement: ``old_text`` between ``start`` and ``old_end`` became ``new_text``
    between ``start`` and ``new_end``."""

    start: Location
    old_end: Location
    new_end: Location
    old_text: str
    new_text: str

    @property
    def is_typing(self) -> bool:
        """One character typed or deleted (what a key press does)."""
        ins = not self.old_text and len(self.new_text) == 1 and self.new_text != "\n"
        dele = not self.new_text and len(self.old_text) == 1 and self.old_text != "\n"
        return ins or dele

    @property
    def starts_typing(self) -> bool:
        """A key press: one character typed or deleted, or typed over a selection (which
        replaces it); the characters typed next join its undo step."""
        over = bool(self.old_text) and len(self.new_text) == 1 and self.new_text != "\n"
        return self.is_typing or over


@dataclass(frozen=True)
class Replacement:
    """What a view must do to follow an undo or redo: replace start..end with text."""

    start: Location
    end: Location
    text: str


@dataclass
class Step:
    """One undo step: the changes it made, in order, and the cursor before and after."""

    label: str
    changes: list[Change] = field(default_factory=list)
    cursor_before: Location = (0, 0)
    cursor_after: Location = (0, 0)
    typing: bool = False
    last_time: float = 0.0


class Document:
    """Text as a list of lines, a version counter and the undo history."""

    def __init__(self, text: str = "") -> None:
        self.lines: list[str] = normalise_newlines(text).split("\n")
        self.version = 0
        self._text: str | None = None
        self._saved_text = self.text
        self._undo: list[Step] = []
        self._redo: list[Step] = []
        self._group: Step | None = None
        self._group_depth = 0
        self._clock = time.monotonic

    # -- reading ----------------------------------------------------------------------
    @property
    def text(self) -> str:
        if self._text is None:
            self._text = "\n".join(self.lines)
        return self._text

    @property
    def modified(self) -> bool:
        """True when the text differs from what was last loaded or saved."""
        return self.text != self._saved_text

    def mark_saved(self, text: str | None = None) -> None:
        self._saved_text = self.text if text is None else normalise_newlines(text)

    @property
    def end(self) -> Location:
        return (len(self.lines) - 1, len(self.lines[-1]))

    def clamp(self, loc: Location) -> Location:
        row = min(max(0, loc[0]), len(self.lines) - 1)
        return (row, min(max(0, loc[1]), len(self.lines[row])))

    def get_range(self, start: Location, end: Location) -> str:
        start, end = sorted((self.clamp(start), self.clamp(end)))
        if start[0] == end[0]:
            return self.lines[start[0]][start[1] : end[1]]
        parts = [self.lines[start[0]][start[1] :]]
        parts += self.lines[start[0] + 1 : end[0]]
        parts.append(self.lines[end[0]][: end[1]])
        return "\n".join(parts)

    def offset(self, loc: Location) -> int:
        """Character offset in :attr:`text` of a location."""
        row, col = self.clamp(loc)
        return sum(len(line) + 1 for line in self.lines[:row]) + col

    def location(self, offset: int) -> Location:
        """Location of a character offset in :attr:`text`."""
        offset = max(0, offset)
        for row, line in enumerate(self.lines):
            if offset <= len(line):
                return (row, offset)
            offset -= len(line) + 1
        return self.end

    # -- changing ---------------------------------------------------------------------
    def _apply(self, start: Location, end: Location, text: str) -> Change:
        start, end = sorted((self.clamp(start), self.clamp(end)))
        text = normalise_newlines(text)
        old = self.get_range(start, end)
        before = self.lines[start[0]][: start[1]]
        after = self.lines[end[0]][end[1] :]
        pieces = text.split("\n")
        new_end = (start[0] + len(pieces) - 1, (len(before) if len(pieces) == 1 else 0) + len(pieces[-1]))
        pieces[0] = before + pieces[0]
        pieces[-1] = pieces[-1] + after
        self.lines[start[0] : end[0] + 1] = pieces
        self.version += 1
        self._text = None
        return Change(start, end, new_end, old, text)

    def replace(self, start: Location, end: Location, text: str, *, cursor: Location | None = None,
                label: str = "edit") -> Change:
        """Replace the text between two locations and record it in the history.

        ``cursor`` is where the cursor was before the change (restored by undo)."""
        change = self._apply(start, end, text)
        if change.old_text == change.new_text:
            return change
        self._record(change, cursor if cursor is not None else change.start, label)
        return change

    def insert(self, at: Location, text: str, **kw) -> Change:
        return self.replace(at, at, text, **kw)

    def set_text(self, text: str, *, label: str = "replace all") -> Change:
        """Replace everything (an undoable step, e.g. reloading from disk or recovering)."""
        return self.replace((0, 0), self.end, text, label=label)

    @contextmanager
    def group(self, label: str, cursor: Location | None = None):
        """Changes made inside the block form one undo step."""
        if self._group_depth == 0:
            self._group = Step(label, cursor_before=cursor or (0, 0))
        self._group_depth += 1
        try:
            yield self
        finally:
            self._group_depth -= 1
            if self._group_depth == 0:
                step, self._group = self._group, None
                if step is not None and step.changes:
                    step.cursor_after = step.changes[-1].new_end
                    self._push(step)

    def _record(self, change: Change, cursor: Location, label: str) -> None:
        self._redo.clear()
        if self._group is not None:
            self._group.changes.append(change)
            return
        now = self._clock()
        last = self._undo[-1] if self._undo else None
        if change.is_typing and last is not None and last.typing and _continues(last, change, now):
            last.changes.append(change)
            last.cursor_after = change.new_end
            last.last_time = now
            return
        typing = change.starts_typing
        step = Step("typing" if typing else label, [change], cursor, change.new_end, typing=typing, last_time=now)
        self._push(step)

    def _push(self, step: Step) -> None:
        self._undo.append(step)
        if len(self._undo) > MAX_STEPS:
            del self._undo[0]

    def break_typing(self) -> None:
        """End the current typing step (the cursor moved away, the file was saved, ...)."""
        if self._undo:
            self._undo[-1].typing = False

    # -- undo and redo ----------------------------------------------------------------
    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    def undo_label(self) -> str | None:
        return self._undo[-1].label if self._undo else None

    def redo_label(self) -> str | None:
        return self._redo[-1].label if self._redo else None

    def undo(self) -> tuple[list[Replacement], Location] | None:
        """Take back the last step; returns the replacements a view must make, and the cursor."""
        if not self._undo:
            return None
        step = self._undo.pop()
        out = []
        for c in reversed(step.changes):
            self._apply(c.start, c.new_end, c.old_text)
            out.append(Replacement(c.start, c.new_end, c.old_text))
        step.typing = False
        self._redo.append(step)
        return out, step.cursor_before

    def redo(self) -> tuple[list[Replacement], Location] | None:
        if not self._redo:
            return None
        step = self._redo.pop()
        out = []
        for c in step.changes:
            self._apply(c.start, c.old_end, c.new_text)
            out.append(Replacement(c.start, c.old_end, c.new_text))
        self._undo.append(step)
        return out, step.cursor_after


def _continues(step: Step, change: Change, now: float) -> bool:
    """Whether a typed character belongs to the typing step before it (same word, no pause)."""
    if now - step.last_time > TYPING_PAUSE:
        return False
    prev = step.changes[-1]
    if change.new_text:  # typed a character
        if prev.new_text == "" or change.start != prev.new_end:
            return False
        return not (change.new_text.isspace() and not prev.new_text.isspace())
    # deleted one character: backspace (ends where the last one started) or delete (same place)
    if prev.new_text:
        return False
    return change.old_end == prev.start or change.start == prev.start

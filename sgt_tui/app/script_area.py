"""The script text area: .sgt highlighting, diagnostics in place, and the editor's one history.

Every change the text area makes (typing, pasting, cutting, and the replacements actions make
through :meth:`ScriptArea.replace`) is forwarded to :class:`sgt_tui.editor.document.Document`
before it is shown, so the document and the view never disagree and undo/redo (which the
document owns) cover typed and action-made changes alike. Meaning never rests on colour
alone: errors are underlined and bold, warnings underlined, and the gutter shows ``E`` or
``W`` after the line number.
"""

from __future__ import annotations

from rich.style import Style
from rich.segment import Segment
from textual.strip import Strip
from textual.widgets import TextArea
from textual.widgets.text_area import Edit, EditHistory, TextAreaTheme

from core.diagnostics import ERROR
from sgt_tui.editor.document import Document, normalise_newlines
from sgt_tui.editor.highlight import line_spans

SYNTAX = {
    "comment": Style(color="bright_black", italic=True),
    "directive": Style(color="magenta", bold=True),
    "speaker": Style(color="cyan", bold=True),
    "tag": Style(color="green", bold=True),
    "name": Style(color="yellow"),
    "value": Style(color="bright_blue"),
    "escape": Style(color="magenta"),
    "sgt-error": Style(color="bright_red", bold=True, underline=True),
    "sgt-warning": Style(color="yellow", underline=True),
}
THEME = TextAreaTheme(name="sgt", syntax_styles=SYNTAX)
MARKS = {"error": ("E", Style(color="bright_red", bold=True)), "warning": ("W", Style(color="yellow", bold=True)),
         "note": ("i", Style(color="cyan"))}


class _NoHistory(EditHistory):
    """The text area's own history is unused: the document keeps the one history."""

    def record(self, edit) -> None:
        return None


class _Highlights(dict):
    """Highlights computed per line when a line is drawn (only visible lines cost anything)."""

    def __init__(self, area: "ScriptArea") -> None:
        super().__init__()
        self.area = area

    def __bool__(self) -> bool:
        return True

    def __getitem__(self, row: int):
        return self.area.line_highlights(row)


class ScriptArea(TextArea):
    """A TextArea bound to a :class:`Document` (the document is the source of truth)."""

    def __init__(self, document: Document, **kw) -> None:
        super().__init__(document.text, soft_wrap=True, show_line_numbers=True, tab_behavior="focus",
                         theme="css", **kw)
        self.core = document
        self.history = _NoHistory(max_checkpoints=1, checkpoint_timer=2.0, checkpoint_max_characters=100)
        self._mirroring = False
        self._highlights = _Highlights(self)
        self.diagnostics: dict[int, list] = {}  # 0-based row -> diagnostics

    def on_mount(self) -> None:
        self.register_theme(THEME)
        self.theme = "sgt"

    # -- highlighting ---------------------------------------------------------------------
    def _build_highlight_map(self) -> None:
        self._line_cache.clear()

    def line_highlights(self, row: int) -> list[tuple[int, int | None, str]]:
        try:
            line = self.document.get_line(row)
        except IndexError:
            return []
        out = [(a, b, c) for a, b, c in line_spans(line)]
        for d in self.diagnostics.get(row, ()):
            a = max(0, min(d.col - 1, max(0, len(line) - 1)))
            b = max(a + 1, min(len(line), d.col - 1 + max(1, d.length)))
            out.append((a, b, "sgt-error" if d.severity == ERROR else "sgt-warning"))
        if not line.isascii():
            offsets = [0]
            for ch in line:
                offsets.append(offsets[-1] + len(ch.encode("utf-8")))
            out = [(offsets[min(a, len(line))], offsets[min(b, len(line))], c) for a, b, c in out]
        return out

    def set_diagnostics(self, by_row: dict[int, list]) -> None:
        self.diagnostics = by_row
        self._line_cache.clear()
        self.refresh()

    def _render_line(self, y: int) -> Strip:
        strip = super()._render_line(y)
        if not self.show_line_numbers or not self.diagnostics:
            return strip
        try:
            row, section = self.wrapped_document._offset_to_line_info[y + self.scroll_offset.y]
        except (IndexError, TypeError):
            return strip
        found = self.diagnostics.get(row)
        if not found or section:
            return strip
        worst = min(found, key=lambda d: {"error": 0, "warning": 1}.get(d.severity, 2)).severity
        char, style = MARKS.get(worst, MARKS["note"])
        at = self.gutter_width - 2
        return Strip.join([strip.crop(0, at), Strip([Segment(char, style)], 1), strip.crop(at + 1, strip.cell_length)])

    # -- every change goes through the document --------------------------------------------
    def edit(self, edit: Edit):
        if self._mirroring:
            return super().edit(edit)
        text = normalise_newlines(edit.text)
        if text != edit.text:
            edit = Edit(text, edit.from_location, edit.to_location, edit.maintain_selection_offset)
        top, bottom = sorted((edit.from_location, edit.to_location))
        self.core.replace(top, bottom, text, cursor=self.cursor_location)
        return super().edit(edit)

    def mirror(self, replacements, cursor) -> None:
        """Show replacements the document already made (undo, redo)."""
        self._mirroring = True
        try:
            for r in replacements:
                super().edit(Edit(r.text, r.start, r.end, False))
        finally:
            self._mirroring = False
        self.move_cursor(cursor)

    def undo(self) -> None:
        self.app.action_undo()

    def redo(self) -> None:
        self.app.action_redo()

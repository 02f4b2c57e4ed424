"""The script text area: .sgt highlighting, diagnostics in place, and the editor's one history.

Every change the text area makes (typing, pasting, cutting, and the replacements actions make
through :meth:`ScriptArea.replace`) is forwarded to :class:`sgt_tui.editor.document.Document`
before it is shown, so the document and the view never disagree and undo/redo (which the
document owns) cover typed and action-made changes alike. Meaning never rests on colour
alone: errors are underlined and bold, warnings underlined, and the gutter shows ``E`` or
``W`` after the line number.

Customised through TextArea's public API only (this class is the one place that does it):

- :meth:`get_line`, the documented hook for styling a line: syntax classes
  (:mod:`sgt_tui.editor.highlight`) and the diagnostics' underlines;
- :meth:`render_line` (the Line API): the ``E``/``W`` mark in the gutter;
- :meth:`edit`: every change goes to the document first; ``history`` records nothing;
- :meth:`type_text`: what a key or a paste types, inserted by the application at the moment it
  handles the key (:meth:`sgt_tui.app.main.EditorApp.on_event` keeps keys in order), as the
  text area's own key handler would (over the selection, the cursor after it);
- ``get_cursor_line_start_location`` / ``get_cursor_line_end_location``: home and end go to
  the start and end of the script line, also on a line wrapped over several rows;
- ``notify_style_update`` drops the rendered lines when the diagnostics change;
- a theme (``register_theme``) whose cursor line sets only the background, so the syntax
  colours (applied in :meth:`get_line`, before the text area's own styles) show on it too.
"""

from __future__ import annotations

from rich.segment import Segment
from rich.style import Style
from rich.text import Text
from textual.binding import Binding
from textual.geometry import Offset
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
}
PROBLEM = {ERROR: Style(color="bright_red", bold=True, underline=True)}
OTHER_PROBLEM = Style(color="yellow", underline=True)
MARKS = {"error": ("E", Style(color="bright_red", bold=True)), "warning": ("W", Style(color="yellow", bold=True)),
         "note": ("i", Style(color="cyan"))}


class _NoHistory(EditHistory):
    """The text area's own history is unused: the document keeps the one history."""

    def record(self, edit) -> None:
        return None


#: A script longer than this (lines) always has a vertical scrollbar (no terminal is taller).
LONG_SCRIPT_LINES = 1000


class ScriptArea(TextArea):
    """A TextArea bound to a :class:`Document` (the document is the source of truth)."""

    # Home and end go to the script line's ends (not the wrapped row's); priority so that they
    # win over the text area's own bindings of the same keys.
    BINDINGS = [
        Binding("ctrl+home", "cursor_to('start')", "start of the script", show=False, priority=True),
        Binding("ctrl+end", "cursor_to('end')", "end of the script", show=False, priority=True),
        Binding("home", "cursor_line_start", "line start", show=False, priority=True),
        Binding("end", "cursor_line_end", "line end", show=False, priority=True),
    ]

    def __init__(self, document: Document, **kw) -> None:
        # Built empty and given the text once (load_text): TextArea's constructor builds and wraps
        # its text several times, seconds for a 1 MB script.
        super().__init__("", soft_wrap=True, show_line_numbers=True, tab_behavior="focus", theme="css", **kw)
        self.load_text(document.text)
        if len(document.lines) > LONG_SCRIPT_LINES:
            # Always a scrollbar: it appearing after the first layout would wrap the text again.
            self.styles.overflow_y = "scroll"
        self.core = document
        self.history = _NoHistory(max_checkpoints=1, checkpoint_timer=2.0, checkpoint_max_characters=100)
        self._mirroring = False
        self.diagnostics: dict[int, list] = {}  # 0-based row -> diagnostics

    def on_mount(self) -> None:
        line = self.get_component_rich_style("text-area--cursor-line")
        self.register_theme(TextAreaTheme("sgt", cursor_line_style=Style(bgcolor=line.bgcolor)))
        self.theme = "sgt"

    # -- highlighting ---------------------------------------------------------------------
    def get_line(self, line_index: int) -> Text:
        text = super().get_line(line_index)
        line = text.plain
        for a, b, cls in line_spans(line):
            text.stylize(SYNTAX[cls], a, b)
        for d in self.diagnostics.get(line_index, ()):
            a = max(0, min(d.col - 1, max(0, len(line) - 1)))
            b = max(a + 1, min(len(line), d.col - 1 + max(1, d.length)))
            text.stylize(PROBLEM.get(d.severity, OTHER_PROBLEM), a, b)
        return text

    def set_diagnostics(self, by_row: dict[int, list]) -> None:
        self.diagnostics = by_row
        self.notify_style_update()  # the rendered lines are cached: draw them again
        self.refresh()

    def render_line(self, y: int) -> Strip:
        strip = super().render_line(y)
        if not self.show_line_numbers or not self.diagnostics:
            return strip
        wrapped = self.wrapped_document
        at = y + self.scroll_offset.y
        if at >= wrapped.height:
            return strip
        row, _ = wrapped.offset_to_location(Offset(0, at))
        found = self.diagnostics.get(row)
        if not found or wrapped.location_to_offset((row, 0)).y != at:  # none, or a wrapped line's later rows
            return strip
        worst = min(found, key=lambda d: {"error": 0, "warning": 1}.get(d.severity, 2)).severity
        char, style = MARKS.get(worst, MARKS["note"])
        x = self.gutter_width - 2
        return Strip.join([strip.crop(0, x), Strip([Segment(char, style)], 1), strip.crop(x + 1, strip.cell_length)])

    # -- moving around --------------------------------------------------------------------
    def get_cursor_line_start_location(self, smart_home: bool = False) -> tuple[int, int]:
        """Home: the script line's first non-blank character (then its start), wrapped or not."""
        row, col = self.cursor_location
        line = self.document.get_line(row)
        first = len(line) - len(line.lstrip())
        return (row, first) if smart_home and (col == 0 or col > first) else (row, 0)

    def get_cursor_line_end_location(self) -> tuple[int, int]:
        """End: the end of the script line, wrapped or not."""
        row, _ = self.cursor_location
        return (row, len(self.document.get_line(row)))

    def action_cursor_to(self, where: str) -> None:
        self.move_cursor((0, 0) if where == "start" else self.document.end)

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

    def type_text(self, text: str, paste: bool = False) -> None:
        """Insert what a key typed (or a paste) over the selection, as the text area's key
        handler would; the cursor ends after it and stays visible while typing."""
        if self.read_only or not text:
            return
        if self.cursor_blink:  # restart the blink: the cursor shows while typing
            self.cursor_blink = False
            self.cursor_blink = True
        result = self.replace(text, *self.selection, maintain_selection_offset=False)
        if paste:
            self.move_cursor(result.end_location)

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

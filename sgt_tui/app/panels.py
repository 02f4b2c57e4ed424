"""Panels around the text area: motion preview, timeline, status line, message line, job bar.

They draw what the editing model (:mod:`sgt_tui.editor`) says; the only state they keep is
their timer. The preview animates only while it is playing *and* on the current screen and
displayed: otherwise no timer runs at all.
"""

from __future__ import annotations

from rich.style import Style
from rich.text import Text
from textual.binding import Binding
from textual.containers import Horizontal
from textual.message import Message
from textual.widget import Widget
from textual.widgets import Label, ProgressBar, Static

from core.skeleton import FPS
from renders.terminal import stick_figure
from sgt_tui.editor.player import Player
from sgt_tui.editor.timeline import TimelineData, layout

MARK_STYLES = {
    "word": Style(),
    "word-current": Style(bold=True, reverse=True),
    "pose": Style(color="green", bold=True),
    "style": Style(color="red", bold=True),
    "pause": Style(dim=True),
    "stroke": Style(color="green", bold=True, underline=True),  # where the stroke lands: "*"
    "stroke-late": Style(color="yellow", bold=True, underline=True),  # a late stroke: "!"
}


def scrub_bindings(action: str) -> list[Binding]:
    """Space plays or pauses; arrows move a frame, shift+arrows (or page keys) a second."""
    return [
        Binding("space", "toggle", "play/pause", show=False),
        Binding("left", f"{action}(-1)", "frame back", show=False),
        Binding("right", f"{action}(1)", "frame on", show=False),
        Binding("shift+left,pageup", f"{action}(-{FPS})", "1 s back", show=False),
        Binding("shift+right,pagedown", f"{action}({FPS})", "1 s on", show=False),
    ]


class PreviewPanel(Widget, can_focus=True):
    """A stick figure drawn with braille characters; space plays, arrows scrub."""

    BINDINGS = scrub_bindings("step") + [Binding("home", "seek(0)", "start", show=False)]

    class FrameChanged(Message):
        """The shown frame changed (playing or scrubbing)."""

    def __init__(self, player: Player, **kw) -> None:
        super().__init__(**kw)
        self.player = player
        self._timer = None
        self.empty_message = "no motion yet"

    # -- the timer runs only while playing and visible ----------------------------------------
    @property
    def animating(self) -> bool:
        return self._timer is not None

    def sync_timer(self) -> None:
        want = (self.player.playing and self.player.n_frames > 0 and self.is_mounted and self.display
                and self.app.screen is self.screen)
        if want and self._timer is None:
            self._timer = self.set_interval(self.player.interval, self._tick)
        elif not want and self._timer is not None:
            self._timer.stop()
            self._timer = None

    def _tick(self) -> None:
        if not self.player.playing:  # a tick already queued when playback stopped
            self.sync_timer()
            return
        self.player.tick()
        self.refresh()
        self.post_message(self.FrameChanged())

    def play(self, on: bool | None = None) -> None:
        if on is None:
            self.player.toggle()
        else:
            self.player.playing = bool(on) and self.player.n_frames > 0
        self.sync_timer()
        self.refresh()

    def action_toggle(self) -> None:
        self.play()

    def action_step(self, frames: int) -> None:
        self.player.step(frames)
        self.refresh()
        self.post_message(self.FrameChanged())

    def action_seek(self, frame: int) -> None:
        self.player.seek(frame)
        self.refresh()
        self.post_message(self.FrameChanged())

    def on_show(self) -> None:
        self.sync_timer()

    def on_hide(self) -> None:
        self.sync_timer()

    def render(self) -> Text:
        w, h = self.content_size
        p = self.player
        state = "▶ playing" if p.playing else "‖ paused"
        caption = f"{state} {p.seconds:4.1f}/{p.n_frames / FPS:.1f}s"
        text = Text(no_wrap=True, overflow="crop")
        pos = p.current()
        rows = max(1, h - 2)
        if pos is None:
            pad = rows // 2
            text.append("\n" * pad + self.empty_message.center(w) + "\n" * (rows - pad))
        else:
            text.append("\n".join(stick_figure(pos, w, rows)) + "\n")
        text.append(caption[:w] + "\n", style=Style(bold=True))
        text.append(p.label[:w], style=Style(italic=True))
        return text


class TimelinePanel(Widget, can_focus=True):
    """Words at their times, pose and style spans, pauses and the playhead (reverse video)."""

    BINDINGS = scrub_bindings("scrub")

    class Scrub(Message):
        def __init__(self, frames: int) -> None:
            super().__init__()
            self.frames = frames

    class Toggle(Message):
        pass

    def __init__(self, **kw) -> None:
        super().__init__(**kw)
        self.data: TimelineData | None = None
        self.playhead: int | None = None
        self.empty_message = ""
        self._drawn: tuple | None = None  # (data, size, playhead column, current word) last drawn

    def show(self, data: TimelineData | None, playhead: int | None, title: str = "", empty: str = "") -> None:
        self.data, self.playhead, self.empty_message = data, playhead, empty
        self.border_title = title
        self._drawn = None
        self.refresh()

    def set_playhead(self, frame: int | None) -> None:
        """Move the playhead; redraw only when its column or the current word changes."""
        if frame == self.playhead:
            return
        self.playhead = frame
        if self._key() != self._drawn:
            self.refresh()

    def _key(self) -> tuple:
        w, _ = self.content_size
        d, f = self.data, self.playhead
        if d is None or f is None or not d.n_frames:
            return (id(d), self.content_size, None, None)
        return (id(d), self.content_size, f * max(1, w - 6) // d.n_frames, d.word_at(f))

    def action_scrub(self, frames: int) -> None:
        self.post_message(self.Scrub(frames))

    def action_toggle(self) -> None:
        self.post_message(self.Toggle())

    def render(self) -> Text:
        w, h = self.content_size
        self._drawn = self._key()
        rows, head = layout(self.data, w, self.playhead, max_lanes=max(1, (h - 2) // 2))
        if not rows:
            return Text(self.empty_message or "no timeline", no_wrap=True, overflow="crop", style=Style(italic=True))
        out = Text(no_wrap=True, overflow="crop")
        for i, r in enumerate(rows[:h]):
            line = Text(r.text[:w])
            line.stylize(Style(dim=True), 0, 6)
            for a, b, cls in r.marks:
                line.stylize(MARK_STYLES.get(cls, Style()), a, b)
            if head is not None and head < w:
                line.stylize(Style(reverse=True), head, head + 1)
            out.append(line)
            if i < min(h, len(rows)) - 1:
                out.append("\n")
        return out


class JobBar(Horizontal):
    """The running job: what, a progress bar, and how to cancel it."""

    def compose(self):
        yield Label("", id="job-label", markup=False)
        yield ProgressBar(total=1000, show_eta=False, id="job-progress")
        yield Label(" ^t cancel", id="job-hint")

    def show_job(self, label: str, fraction: float, what: str = "") -> None:
        self.display = True
        self.query_one("#job-label", Label).update(f"{label} {what}"[:34])
        self.query_one("#job-progress", ProgressBar).update(progress=int(1000 * max(0.0, min(1.0, fraction))))


class StatusLine(Static):
    """File, problems, utterance, engine (plain text: file names may hold brackets)."""

    def __init__(self, text: str = "", **kw) -> None:
        super().__init__(text, markup=False, **kw)


class MessageLine(Static):
    """The problem under the cursor, else the last message (plain text: it quotes ``[pose:...]``)."""

    def __init__(self, text: str = "", **kw) -> None:
        super().__init__(text, markup=False, **kw)

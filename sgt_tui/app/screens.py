"""Dialogs over the editor: problems list, motion library, style, and choices.

Each returns its answer with ``dismiss``; the application does the edit through the editing
model, so every action is one undo step.
"""

from __future__ import annotations

from rich.style import Style
from rich.text import Text
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.screen import ModalScreen
from textual.widget import Widget
from textual.widgets import Button, OptionList, Static
from textual.widgets.option_list import Option

from dsl.presets import BUILTIN_PRESETS
from core.controls import STYLE_LIMIT, STYLE_NAMES
from core.skeleton import positions_from_pose
from sgt_tui.app.panels import PreviewPanel
from sgt_tui.editor.edits import pose_tag
from sgt_tui.editor.player import Player

SEVERITY_MARK = {"error": "E", "warning": "W", "note": "i"}


class ChoiceScreen(ModalScreen[str]):
    """A question with a few answers, each on a key; escape picks the last (the safe one)."""

    def __init__(self, title: str, message: str, choices: list[tuple[str, str]]) -> None:
        super().__init__()
        self.title_text, self.message, self.choices = title, message, choices
        self.answered = False

    def compose(self):
        with Vertical(id="dialog"):
            yield Static(self.title_text, id="dialog-title")
            yield Static(self.message, id="dialog-message")
            with Horizontal(id="dialog-buttons"):
                for key, label in self.choices:
                    yield Button(f"[{key}] {label}", id=f"choice-{key}", compact=True)

    def answer(self, key: str) -> None:
        if not self.answered:  # keys typed quickly may arrive after the first answer
            self.answered = True
            self.dismiss(key)

    def on_key(self, event) -> None:
        keys = {k for k, _ in self.choices}
        if event.key in keys:
            event.stop()
            self.answer(event.key)
        elif event.key == "escape":
            event.stop()
            self.answer(self.choices[-1][0])

    def on_button_pressed(self, event: Button.Pressed) -> None:
        self.answer(event.button.id.removeprefix("choice-"))


class ProblemsScreen(ModalScreen):
    """Every problem of the script; enter jumps to it."""

    BINDINGS = [Binding("escape", "dismiss(None)", "close")]

    def __init__(self, diagnostics: list) -> None:
        super().__init__()
        self.diagnostics = diagnostics

    def compose(self):
        with Vertical(id="dialog"):
            n = len(self.diagnostics)
            yield Static(f"Problems ({n}) · enter: go to · esc: close", id="dialog-title")
            options = []
            for i, d in enumerate(self.diagnostics):
                mark = SEVERITY_MARK.get(d.severity, "?")
                where = f"{d.line}:{d.col}" if d.line else d.file
                options.append(Option(f"{mark} {where:>7} {d.severity}: {d.message}", id=str(i)))
            if not options:
                options.append(Option("no problems", id="none", disabled=True))
            yield OptionList(*options, id="problem-list")

    def on_option_list_option_selected(self, event: OptionList.OptionSelected) -> None:
        if event.option.id and event.option.id.isdigit():
            self.dismiss(self.diagnostics[int(event.option.id)])


class LibraryScreen(ModalScreen):
    """The motion library with a looping preview; returns the ``[pose:...]`` text to insert."""

    BINDINGS = [
        Binding("escape", "dismiss(None)", "close"),
        Binding("1", "speed(1)", "x1"),
        Binding("2", "speed(2)", "x2"),
        Binding("3", "speed(3)", "x3"),
        Binding("f", "flip", "flip"),
        Binding("space", "toggle", "play/pause", show=False),
    ]

    def __init__(self, library) -> None:
        super().__init__()
        self.library = library
        self.names = library.names()
        self.speed = 1
        self.flip = False
        self.current: str | None = self.names[0] if self.names else None
        self.player = Player(playing=True)

    def compose(self):
        with Vertical(id="library-dialog"):
            yield Static("Motion library · 1/2/3 speed · f flip · enter insert · esc close", id="dialog-title")
            with Horizontal():
                yield OptionList(*[Option(f"{g.name:<14}{g.duration:>4.1f}s", id=g.name) for g in self.library],
                                 id="gesture-list")
                with Vertical(id="library-right"):
                    yield PreviewPanel(self.player, id="library-preview")
                    yield Static("", id="gesture-info")

    def on_mount(self) -> None:
        self._load()

    def on_option_list_option_highlighted(self, event: OptionList.OptionHighlighted) -> None:
        self.current = event.option.id
        self._load()

    def on_option_list_option_selected(self, event: OptionList.OptionSelected) -> None:
        self.current = event.option.id
        self.dismiss(self.tag())

    def tag(self) -> str | None:
        return pose_tag(self.current, self.speed, self.flip) if self.current else None

    def _load(self) -> None:
        preview = self.query_one(PreviewPanel)
        info = self.query_one("#gesture-info", Static)
        g = self.library.get(self.current) if self.current else None
        if g is None:
            self.player.load(None, "")
            info.update("no gestures")
            preview.sync_timer()
            return
        clip = g.clip(speed=self.speed, flip=self.flip)
        self.player.load(positions_from_pose(clip.poses), f"{g.name} x{self.speed}" + (" flip" if self.flip else ""),
                         keep_frame=False)
        preview.sync_timer()
        preview.refresh()
        stroke = f"stroke at frame {clip.stroke_frame}" if clip.stroke_frame is not None else "no stroke"
        info.update(f"{self.tag()}\n{g.description}\ntags: {', '.join(g.tags) or '-'}\n"
                    f"{clip.n_frames} frames ({clip.duration:.2f} s), {stroke}")

    def action_speed(self, speed: int) -> None:
        self.speed = speed
        self._load()

    def action_flip(self) -> None:
        self.flip = not self.flip
        self._load()

    def action_toggle(self) -> None:
        self.query_one(PreviewPanel).play()


class StyleSlider(Widget, can_focus=True):
    """One style element: left/right change it by 0.5 in [-3, 3]; x (or delete) unsets it."""

    BINDINGS = [
        Binding("left", "nudge(-0.5)", "-0.5", show=False),
        Binding("right", "nudge(0.5)", "+0.5", show=False),
        Binding("x,delete,backspace", "unset", "unset", show=False),
    ]

    def __init__(self, name: str, value: float | None = None, **kw) -> None:
        super().__init__(**kw)
        self.element = name
        self.value = value

    def action_nudge(self, step: float) -> None:
        v = 0.0 if self.value is None else self.value
        self.value = max(-STYLE_LIMIT, min(STYLE_LIMIT, v + step))
        self.refresh()

    def action_unset(self) -> None:
        self.value = None
        self.refresh()

    def render(self) -> Text:
        w = max(10, self.content_size.width - 30)
        text = Text(no_wrap=True, overflow="crop")
        text.append(f"{'▸' if self.has_focus else ' '} {self.element:<11}", style=Style(bold=self.has_focus))
        if self.value is None:
            text.append("-3 " + "·" * w + " +3  not set")
            return text
        pos = int(round((self.value + STYLE_LIMIT) / (2 * STYLE_LIMIT) * (w - 1)))
        bar = "─" * pos + "●" + "─" * (w - 1 - pos)
        text.append("-3 " + bar + " +3", style=Style(bold=True))
        text.append(f"  {self.value:+.1f}")
        return text

    def on_focus(self) -> None:
        self.refresh()

    def on_blur(self) -> None:
        self.refresh()


class StyleScreen(ModalScreen):
    """Style for the selected words: sliders and presets; returns {"values", "preset"}."""

    KEYS_HELP = "↑↓ choose · ←→ change · x unset · enter apply · h happy · s sad · a angry · c calm · esc cancel"
    BINDINGS = [
        Binding("escape", "dismiss(None)", "cancel"),
        Binding("enter", "apply", "apply"),
        Binding("up", "app.focus_previous", "previous", show=False),
        Binding("down", "app.focus_next", "next", show=False),
        Binding("h", "preset('happy')", "happy"),
        Binding("s", "preset('sad')", "sad"),
        Binding("a", "preset('angry')", "angry"),
        Binding("c", "preset('calm')", "calm"),
    ]

    def __init__(self, selected: str, user_presets: dict | None = None) -> None:
        super().__init__()
        self.selected = selected
        self.presets = list(BUILTIN_PRESETS) + sorted(user_presets or {})

    def compose(self):
        with Vertical(id="dialog"):
            shown = self.selected if len(self.selected) <= 60 else self.selected[:57] + "..."
            yield Static(f"Style for: {shown}", id="dialog-title")
            for name in STYLE_NAMES:
                yield StyleSlider(name, id=f"slider-{name}")
            with Horizontal(id="preset-buttons"):
                for p in self.presets:
                    yield Button(p, id=f"preset-{p}", compact=True)
            yield Static(self.KEYS_HELP, id="dialog-message")

    def on_mount(self) -> None:
        self.query_one(StyleSlider).focus()

    def values(self) -> dict[str, float]:
        return {s.element: s.value for s in self.query(StyleSlider) if s.value is not None}

    def action_apply(self) -> None:
        values = self.values()
        self.dismiss({"values": values, "preset": None} if values else None)

    def action_preset(self, name: str) -> None:
        self.dismiss({"values": self.values(), "preset": name})

    def on_button_pressed(self, event: Button.Pressed) -> None:
        self.action_preset(event.button.id.removeprefix("preset-"))


class KeysScreen(ModalScreen):
    """Every key of the editor, with what it does."""

    BINDINGS = [Binding("escape,f1,q", "dismiss(None)", "close")]

    def __init__(self, rows: list[tuple[str, str, str]]) -> None:
        super().__init__()
        self.rows = rows

    def compose(self):
        with Vertical(id="dialog"):
            yield Static("Keys · esc closes · ctrl+p: command palette", id="dialog-title")
            width = max(len(k) for k, _, _ in self.rows)
            lines = [f"{k:<{width}}  {title}: {help_}" for k, title, help_ in self.rows]
            lines += ["", "preview/timeline (tab to focus): space play, ←→ frame, shift+←→ second",
                      "text: shift+arrows select, f6 line, f7 all, ctrl+x/c/v cut/copy/paste"]
            yield OptionList(*[Option(t, disabled=False) for t in lines], id="keys-list")

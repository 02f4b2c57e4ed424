"""Dialogs over the editor: problems list, motion library, style, choices, go to, save as.

Each returns its answer with ``dismiss``; the application does the edit through the editing
model, so every action is one undo step. Text that comes from the user or the script (file
names, messages quoting ``[pose:...]``, the ``[s]`` of a choice) is shown as it is, never read
as Textual markup. Read-only panels (problems, keys) also close with ``q``: tmux's default
escape-time makes ``esc`` take 0.6 s there.
"""

from __future__ import annotations

from dataclasses import dataclass

from rich.style import Style
from rich.text import Text
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.content import Content
from textual.screen import ModalScreen
from textual.widget import Widget
from textual.widgets import Button, Input, OptionList, Static
from textual.widgets.option_list import Option

from core.controls import STYLE_LIMIT, STYLE_NAMES
from core.counting import plural
from core.diagnostics import Diagnostic, Fix
from core.skeleton import positions_from_pose
from dsl.presets import BUILTIN_PRESETS
from renders.terminal import figure_points
from sgt_tui.app.actions import TEXT_KEYS
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
            yield Static(self.title_text, id="dialog-title", markup=False)
            yield Static(self.message, id="dialog-message", markup=False)
            with Horizontal(id="dialog-buttons"):
                for key, label in self.choices:
                    yield Button(Content(f"[{key}] {label}"), id=f"choice-{key}", compact=True)

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


@dataclass(frozen=True)
class Picked:
    """The problems list's answer: go to ``diagnostic``, and apply ``fix`` when one was chosen."""

    diagnostic: Diagnostic
    fix: Fix | None = None


def problem_prompt(d: Diagnostic) -> Content:
    """One problem: mark, place, message; under it the did-you-mean and the fixes with their keys."""
    mark = SEVERITY_MARK.get(d.severity, "?")
    where = f"{d.line}:{d.col}" if d.line else ""
    lines = [f"{mark} {where:>7} {d.severity}: {d.message}"]
    if d.hint:
        lines.append(f"          {d.hint}")
    for i, fix in enumerate(d.fixes[:9]):
        lines.append(f"          {'f' if i == 0 else i + 1}: {fix.title}")
    return Content("\n".join(lines))


class ProblemsScreen(ModalScreen):
    """Every problem of the script; enter jumps to it, ``f`` (or 2-9) applies its suggested fix."""

    BINDINGS = [Binding("escape,q,f2", "dismiss(None)", "close"), Binding("f", "fix(0)", "fix")]
    BINDINGS += [Binding(str(n), f"fix({n - 1})", show=False) for n in range(2, 10)]

    def __init__(self, diagnostics: list[Diagnostic]) -> None:
        super().__init__()
        self.diagnostics = diagnostics

    def compose(self):
        with Vertical(id="dialog"):
            n = len(self.diagnostics)
            yield Static(f"Problems ({n}) · enter: go to · f: apply the fix · q: close", id="dialog-title",
                         markup=False)
            options = [Option(problem_prompt(d), id=str(i)) for i, d in enumerate(self.diagnostics)]
            if not options:
                options.append(Option("no problems", id="none", disabled=True))
            yield OptionList(*options, id="problem-list")
            yield Static("", id="problem-note", markup=False)

    def current(self) -> Diagnostic | None:
        option_list = self.query_one(OptionList)
        i = option_list.highlighted
        if i is None or not self.diagnostics:
            return None
        return self.diagnostics[int(option_list.get_option_at_index(i).id)]

    def on_option_list_option_selected(self, event: OptionList.OptionSelected) -> None:
        if event.option.id and event.option.id.isdigit():
            self.dismiss(Picked(self.diagnostics[int(event.option.id)]))

    def action_fix(self, n: int) -> None:
        d = self.current()
        if d is None:
            return
        if n >= len(d.fixes):
            self.query_one("#problem-note", Static).update(
                "this problem has no suggested fix" if not d.fixes else f"it has {len(d.fixes)} fixes: f or 2-{len(d.fixes)}")
            return
        self.dismiss(Picked(d, d.fixes[n]))


class FilterInput(Input):
    """The library's filter: it takes what names and tags are made of; 1/2/3 and space stay the
    dialog's keys (speed, play/pause)."""

    def check_consume_key(self, key: str, character: str | None = None) -> bool:
        return character not in ("1", "2", "3", " ") and super().check_consume_key(key, character)


class LibraryScreen(ModalScreen):
    """The motion library with a looping preview; returns the ``[pose:...]`` text to insert.

    Typing filters the list (by name and tag); the other keys are not letters."""

    KEYS_HELP = "type to filter · 1/2/3 speed · ^f flip · enter insert · f3 close"
    BINDINGS = [
        Binding("escape,f3", "dismiss(None)", "close"),
        Binding("up", "move(-1)", "previous", show=False, priority=True),
        Binding("down", "move(1)", "next", show=False, priority=True),
        Binding("1", "speed(1)", "x1", priority=True),
        Binding("2", "speed(2)", "x2", priority=True),
        Binding("3", "speed(3)", "x3", priority=True),
        Binding("ctrl+f", "flip", "flip", priority=True),
        Binding("space", "toggle", "play/pause", show=False, priority=True),
    ]

    def __init__(self, library) -> None:
        super().__init__()
        self.library = library
        self.names = library.names()
        self.shown: list[str] = list(self.names)
        self.speed = 1
        self.flip = False
        self.current: str | None = self.names[0] if self.names else None
        self.player = Player(playing=True)

    def compose(self):
        with Vertical(id="library-dialog"):
            yield Static("Library · " + self.KEYS_HELP, id="dialog-title", markup=False)
            yield FilterInput(placeholder="filter: type part of a name or tag", id="gesture-filter", compact=True)
            with Horizontal():
                yield OptionList(*self._options(), id="gesture-list")
                with Vertical(id="library-right"):
                    yield PreviewPanel(self.player, id="library-preview")
                    yield Static("", id="gesture-info", markup=False)

    def _options(self) -> list[Option]:
        return [Option(f"{g.name:<14}{g.duration:>4.1f}s", id=g.name) for g in self.library if g.name in self.shown]

    def on_mount(self) -> None:
        box = self.query_one(Input)
        box.cursor_blink = self.app.cursor_blink
        box.focus()
        self._load()

    def on_input_changed(self, event: Input.Changed) -> None:
        words = event.value.lower().split()
        self.shown = [g.name for g in self.library
                      if all(w in g.name.lower() or any(w in t.lower() for t in g.tags) for w in words)]
        option_list = self.query_one(OptionList)
        option_list.clear_options()
        option_list.add_options(self._options())
        if self.shown:
            option_list.highlighted = 0
        self.current = self.shown[0] if self.shown else None
        self._load()

    def on_input_submitted(self, event: Input.Submitted) -> None:
        event.stop()
        if self.current is not None:
            self.dismiss(self.tag())

    def action_move(self, step: int) -> None:
        option_list = self.query_one(OptionList)
        if step < 0:
            option_list.action_cursor_up()
        else:
            option_list.action_cursor_down()

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
            info.update("no gesture matches the filter" if self.names else "no gestures")
            preview.sync_timer()
            preview.refresh()
            return
        clip = g.clip(speed=self.speed, flip=self.flip)
        self.player.load(figure_points(positions_from_pose(clip.poses), clip.hands), f"{g.name} x{self.speed}" + (" flip" if self.flip else ""),
                         keep_frame=False)
        preview.sync_timer()
        preview.refresh()
        stroke = f"stroke at frame {clip.stroke_frame}" if clip.stroke_frame is not None else "no stroke"
        info.update(f"{self.tag()}\n{g.description}\ntags: {', '.join(g.tags) or '-'}\n"
                    f"{plural(clip.n_frames, 'frame')} ({clip.duration:.2f} s), {stroke}")

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
            yield Static(f"Style for: {shown}", id="dialog-title", markup=False)
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
            yield Static("Keys · q or esc closes · ctrl+p: command palette", id="dialog-title", markup=False)
            width = max(len(k) for k, _, _ in self.rows)
            lines = [f"{k:<{width}}  {title}: {help_}" for k, title, help_ in self.rows]
            lines += ["", *TEXT_KEYS]
            yield OptionList(*[Option(Content(t)) for t in lines], id="keys-list")


class AskScreen(ModalScreen):
    """A question answered by typing a line (go to, save as); returns the text, or None (esc)."""

    BINDINGS = [Binding("escape", "dismiss(None)", "cancel")]

    def __init__(self, title: str, message: str, value: str = "", placeholder: str = "") -> None:
        super().__init__()
        self.title_text, self.message, self.value, self.placeholder = title, message, value, placeholder

    def compose(self):
        with Vertical(id="dialog"):
            yield Static(self.title_text, id="dialog-title", markup=False)
            yield Static(self.message, id="dialog-message", markup=False)
            yield Input(self.value, placeholder=self.placeholder, id="ask-input", select_on_focus=False)

    def on_mount(self) -> None:
        box = self.query_one(Input)
        box.cursor_blink = self.app.cursor_blink
        box.focus()

    def on_input_submitted(self, event: Input.Submitted) -> None:
        event.stop()
        self.dismiss(event.value.strip() or None)

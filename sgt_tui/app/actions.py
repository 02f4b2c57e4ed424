"""Every action of the editor, once: its key, footer label, title, help, and the palette.

:data:`ACTIONS` is the one table: the application's key bindings, the footer, the keys list
(F1), docs/editor.md's keys table (a test keeps them in step) and the command palette all come
from it. An action is a method ``action_NAME`` of the application called with ``args``; the
binding's action string is built from those, and the palette calls the method directly, so
nothing parses an action string back. Keys avoid ctrl+shift combinations and keys terminals or
tmux take for themselves (no ``ctrl+b``, ``f10``, ``f11``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Callable

from textual.binding import Binding
from textual.command import DiscoveryHit, Hit, Hits, Provider
from textual.content import Content
from textual.markup import escape

from dsl.presets import BUILTIN_PRESETS
from model.engines import ENGINES

ENGINE_ORDER = tuple(ENGINES)  # the order ctrl+e cycles through: the default first (model.engines)


@dataclass(frozen=True)
class Act:
    key: str
    name: str  # the application's method is action_NAME
    footer: str  # short label in the footer ("" = not in the footer)
    title: str  # command palette title
    help: str
    args: tuple = ()

    @property
    def action(self) -> str:
        """The binding's action string, built from the name and arguments."""
        return f"{self.name}({', '.join(repr(a) for a in self.args)})" if self.args else self.name

    def run(self, app) -> object:
        return getattr(app, f"action_{self.name}")(*self.args)


ACTIONS: tuple[Act, ...] = (
    Act("ctrl+s", "save", "save", "Save", "write the script (atomically; asks if it changed on disk, offers save as if it cannot)"),
    Act("ctrl+z", "undo", "", "Undo", "take back the last change, typed or made by an action"),
    Act("ctrl+y", "redo", "", "Redo", "make the undone change again"),
    Act("f1", "keys", "keys", "Keys", "list every key"),
    Act("f2", "problems", "probs", "Problems", "list every problem; enter jumps to it, f applies its fix"),
    Act("ctrl+n", "next_problem", "", "Next problem", "jump to the next problem after the cursor"),
    Act("ctrl+f", "quick_fix", "", "Quick fix", "apply the suggested fix of the problem at the cursor"),
    Act("ctrl+l", "goto", "", "Go to line or utterance", "jump to a line (12) or an utterance (u3)"),
    Act("f3", "library", "lib", "Motion library", "browse gestures with a live preview; insert one at the cursor"),
    Act("f4", "style", "style", "Style the selection", "speed, space, handedness or a preset for the selected words"),
    Act("alt+left", "move_pose", "", "Pose to previous word", "move the pose control at the cursor to the previous word", (-1,)),
    Act("alt+right", "move_pose", "", "Pose to next word", "move the pose control at the cursor to the next word", (1,)),
    Act("f6", "suggest", "", "Suggest gestures", "put the gestures the words of the utterance at the cursor call for "
        "where it has no mark (as sgt suggest; one undo takes them back)"),
    Act("f5", "play", "play", "Play / pause", "play or pause the motion preview (15 fps)"),
    Act("ctrl+g", "job", "gen", "Generate utterance", "generate motion for the utterance at the cursor", ("generate", False)),
    Act("f8", "job", "", "Generate script", "generate motion for the whole script", ("generate", True)),
    Act("f9", "job", "gif", "Render GIF of utterance", "render the utterance at the cursor to a GIF (lobby.u2.gif: utterance 2)",
        ("render", False)),
    Act("ctrl+r", "job", "", "Render GIF of script", "render the whole script to a GIF", ("render", True)),
    Act("ctrl+t", "cancel_job", "", "Cancel job", "cancel the job asked for last: the last queued, else the running one"),
    Act("ctrl+o", "next_engine", "", "Next engine", "switch the generation engine: neural, matching, keyframe, rules"),
    Act("ctrl+q", "quit", "quit", "Quit", "leave the editor (asks about unsaved changes)"),
    Act("ctrl+p", "command_palette", "", "Command palette", "search every action by name"),
)
#: Footer order (the most used first; everything else is in F1 and the palette, which the
#: footer shows on its right as ``^p cmds``). ctrl+z is left out: everyone knows it.
FOOTER_ORDER = ("ctrl+s", "f1", "f2", "f3", "f4", "f5", "ctrl+g", "f9", "ctrl+q")
#: The editor's own actions (they act on the main screen only; dialogs have their own keys).
ACTION_NAMES = frozenset(a.name for a in ACTIONS) - {"command_palette"}


def bindings() -> list[Binding]:
    """The application's bindings, footer entries first, in :data:`FOOTER_ORDER`."""
    def order(a: Act) -> int:
        return FOOTER_ORDER.index(a.key) if a.key in FOOTER_ORDER else len(FOOTER_ORDER)

    return [Binding(a.key, a.action, a.footer or a.title, show=bool(a.footer), priority=True)
            if a.name != "command_palette" else
            Binding(a.key, a.action, "cmds", show=False, priority=True)  # the footer shows it on its right
            for a in sorted(ACTIONS, key=order)]


@dataclass(frozen=True)
class Command:
    """One entry of the command palette."""

    title: str
    key: str  # "" when only the palette has it
    help: str
    run: Callable[[], object]

    def prompt(self, title: Content | None = None) -> Content:
        shown = title if title is not None else Content(self.title)
        return Content.assemble(shown, ("  " + self.key, "dim")) if self.key else shown


def commands(app) -> list[Command]:
    """Every palette entry: the actions (with their keys), then what only the palette offers."""
    out = [Command(a.title, a.key, a.help, partial(a.run, app)) for a in ACTIONS if a.name != "command_palette"]
    out += [
        Command("Go to utterance", "", "jump to utterance N (counting from 1, as the status line)",
                partial(app.action_goto, "u")),
        Command("Save as", "", "write the script under another name (it becomes the file being edited)",
                app.action_save_as),
    ]
    out += [Command(f"Engine: {name}", "", f"generate with the {name} engine", partial(app.set_engine, name))
            for name in ENGINE_ORDER]
    out += [Command(f"Style preset: {p}", "", f"wrap the selected words in <{p}>", partial(app.apply_style, None, p))
            for p in BUILTIN_PRESETS]
    return out


class EditorCommands(Provider):
    """The command palette (ctrl+p): every action once, with its key."""

    async def discover(self) -> Hits:
        for c in commands(self.app):
            yield DiscoveryHit(c.prompt(), c.run, text=c.title, help=escape(c.help))

    async def search(self, query: str) -> Hits:
        matcher = self.matcher(query)
        for c in commands(self.app):
            score = matcher.match(c.title)
            if score > 0:
                yield Hit(score, c.prompt(matcher.highlight(c.title)), c.run, text=c.title, help=escape(c.help))

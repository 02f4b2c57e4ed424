"""`sgt edit`'s pose mode (f12): make a gesture with the keys, for a terminal with no browser (docs/editor.md).

The editing model is :class:`sgt_tui.editor.posing.PoseSession` (the same inverse kinematics as
``sgt view``'s page, :mod:`core.ik`); this screen draws the keyframe shown in the preview (the
editor's stick figure, :class:`sgt_tui.app.panels.PreviewPanel`), says what is selected, and maps
the keys. Saving writes into the script's first ``@library`` folder; enter closes it and inserts
``[pose:NAME]`` at the cursor (the application does the edit: one undo step).
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

from textual.binding import Binding
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import Static

from core.fileio import OutputError
from core.reading import InputFileError, read_bytes
from library.posing import DraftError, FileChanged, GestureExists, sha256_of
from library.spec import NAME_RE
from sgt_tui.app.panels import PreviewPanel
from sgt_tui.app.screens import AskScreen
from sgt_tui.editor.edits import pose_tag
from sgt_tui.editor.player import Player
from sgt_tui.editor.posing import PoseSession

KEYS_HELP = ("tab joint · arrows move · f/b nearer/farther · [ ] twist · h/p hand/palm · , . keyframe · k/x add/remove · "
             "s stroke · l label · m mirror · z/y undo/redo · space play · c this frame · o open · n new · w save · "
             "enter insert · esc")


class PoseScreen(ModalScreen):
    """The pose mode (the module's docstring); returns the ``[pose:NAME]`` to insert, or None."""

    BINDINGS: ClassVar[list[Binding]] = [
        Binding("escape", "dismiss(None)", "close"),
        Binding("tab", "select(1)", "next joint", priority=True),
        Binding("shift+tab", "select(-1)", "previous joint", priority=True),
        Binding("left", "move(-1, 0, 0)", "left", priority=True),
        Binding("right", "move(1, 0, 0)", "right", priority=True),
        Binding("up", "move(0, 1, 0)", "up", priority=True),
        Binding("down", "move(0, -1, 0)", "down", priority=True),
        Binding("f", "move(0, 0, 1)", "nearer", priority=True),
        Binding("b", "move(0, 0, -1)", "farther", priority=True),
        Binding("left_square_bracket", "twist(-1)", "twist", priority=True),
        Binding("right_square_bracket", "twist(1)", "twist", priority=True),
        Binding("h", "hand('hand')", "hand", priority=True),
        Binding("p", "hand('palm')", "palm", priority=True),
        Binding("comma", "key(-1)", "previous keyframe", priority=True),
        Binding("full_stop", "key(1)", "next keyframe", priority=True),
        Binding("k", "add_key", "add keyframe", priority=True),
        Binding("x", "remove_key", "remove keyframe", priority=True),
        Binding("s", "stroke", "stroke", priority=True),
        Binding("l", "label", "label", priority=True),
        Binding("m", "mirror", "mirror", priority=True),
        Binding("z", "undo", "undo", priority=True),
        Binding("y", "redo", "redo", priority=True),
        Binding("space", "play", "play", priority=True),
        Binding("c", "this_frame", "this frame", priority=True),
        Binding("o", "open", "open", priority=True),
        Binding("n", "new", "new", priority=True),
        Binding("w", "save", "save", priority=True),
        Binding("enter", "insert", "insert", priority=True),
    ]

    def __init__(self, library, folders: list[Path], frame=None, start: str | None = None) -> None:
        super().__init__()
        self.library = library
        self.folders = list(folders)
        self.frame = frame  # the editor's preview frame (joints first), for "c"
        self.session = PoseSession()
        self.player = Player()
        self.saved = None  # the text last saved (the gesture can be inserted while it is unchanged)
        self.message = ""
        self._ready = False
        if start is not None:
            self._open(start)

    def compose(self):
        with Vertical(id="pose-dialog"):
            yield Static("Pose · " + KEYS_HELP, id="dialog-title", markup=False)
            yield PreviewPanel(self.player, id="pose-preview")
            yield Static("", id="pose-info", markup=False)
            yield Static("", id="pose-message", markup=False)

    def on_mount(self) -> None:
        self._ready = True
        self.query_one(PreviewPanel).empty_message = "no pose"
        self._show()

    # -- showing -------------------------------------------------------------------------------

    def _show(self, message: str | None = None) -> None:
        if message is not None:
            self.message = message
        if not self._ready:  # (before on_mount: nothing to draw in yet)
            return
        preview = self.query_one(PreviewPanel)
        if not self.player.playing:
            self.player.load(self.session.points(), f"keyframe {self.session.key + 1} · {self.session.joint.replace('_', ' ')}",
                             keep_frame=False)
        preview.sync_timer()
        preview.refresh()
        folder = self._folder()
        where = f"saves in {_short(folder)}/" if folder else "add @library FOLDER to the script's header to save"
        dirty = " · not saved" if self.saved != self.session.draft.to_dict() else " · saved"
        self.query_one("#pose-info", Static).update(self.session.describe() + f"\n{where}{dirty}")
        self.query_one("#pose-message", Static).update(self.message)

    def _folder(self) -> Path | None:
        return self.folders[0] if self.folders else None

    def _edited(self, changed: bool, nothing: str = "nothing to change") -> None:
        self._stop()
        self._show("" if changed else nothing)

    def _stop(self) -> None:
        if self.player.playing:
            self.player.playing = False
            self.query_one(PreviewPanel).sync_timer()

    # -- the keys ------------------------------------------------------------------------------

    def action_select(self, step: int) -> None:
        self.session.select(step)
        self._edited(True)

    def action_move(self, right: int, up: int, near: int) -> None:
        self._edited(self.session.move(right, up, near), "it goes no farther (the joint's limit)")

    def action_twist(self, step: int) -> None:
        self._edited(self.session.twist(step), "the palm stays: twist more")

    def action_hand(self, what: str) -> None:
        self._edited(self.session.cycle_hand(what))

    def action_key(self, step: int) -> None:
        self.session.goto(step)
        self._edited(True)

    def action_add_key(self) -> None:
        self._edited(self.session.add_key())

    def action_remove_key(self) -> None:
        self._edited(self.session.remove_key(), "a gesture keeps one keyframe at least")

    def action_stroke(self) -> None:
        self._edited(self.session.toggle_stroke())

    def action_mirror(self) -> None:
        self._edited(self.session.mirror())

    def action_undo(self) -> None:
        self._edited(self.session.undo(), "nothing to undo")

    def action_redo(self) -> None:
        self._edited(self.session.redo(), "nothing to redo")

    def action_new(self) -> None:
        self.session = PoseSession()
        self.saved = None
        self._edited(True)

    def action_this_frame(self) -> None:
        if self.frame is None:
            self._show("the preview shows no motion: generate the utterance first (ctrl+g)")
            return
        self._edited(self.session.from_positions(self.frame[:10]))

    def action_label(self) -> None:
        def done(text: str | None) -> None:
            if text is not None:
                self._edited(self.session.set_label(text))

        self.app.push_screen(AskScreen("Label", "the keyframe's label (start, prepare, stroke, hold, retract, ...)",
                                       self.session.current.label), done)

    def action_play(self) -> None:
        if self.player.playing:
            self._stop()
            self._show("")
            return
        try:
            frames, stroke = self.session.clip()
        except DraftError as exc:
            self._show(str(exc))
            return
        self.player.load(frames, f"{self.session.draft.name} · the stroke at frame {stroke}", keep_frame=False)
        self.query_one(PreviewPanel).play(True)
        self._show(f"playing {self.session.draft.name}: {len(frames)} frames; space stops")

    def action_open(self) -> None:
        def done(name: str | None) -> None:
            if name:
                self._open(name)
                self._show()

        self.app.push_screen(AskScreen("Open a gesture", "the name of a gesture to start from (f3 lists them)"), done)

    def _open(self, name: str) -> None:
        g = self.library.get(name) if self.library is not None else None
        if g is None:
            hint = self.library.suggest(name) if self.library is not None else None
            self.message = f"no gesture named '{name}'" + (f"; did you mean '{hint}'?" if hint else "")
            return
        try:
            sha = sha256_of(read_bytes(g.path, "gesture spec"))
        except (InputFileError, OSError):
            sha = None
        self.session = PoseSession.of_gesture(g, sha)
        self.saved = self.session.draft.to_dict() if g.origin != "built-in" else None
        self.message = f"opened {name} ({g.origin if g.origin == 'built-in' else g.path})"

    def action_save(self) -> None:
        folder = self._folder()
        if folder is None:
            self._show("the script has no @library folder: add '@library gestures' to its header, save it, then save here")
            return

        def named(name: str | None) -> None:
            if name is None:
                return
            if not NAME_RE.match(name):
                self._show(f"'{name}' is not a gesture name: lower-case letters, digits and _, starting with a letter")
                return
            if name != self.session.draft.name:
                self.session.rename(name)
            self._save(folder, replace=False)

        self.app.push_screen(AskScreen("Save as gesture", f"its name (saved as {_short(folder)}/NAME.toml)", self.session.draft.name),
                             named)

    def _save(self, folder: Path, replace: bool) -> None:
        name = self.session.draft.name
        known = self.library.get(name) if self.library is not None else None
        elsewhere = None
        if known is not None and Path(known.path).parent.resolve() != Path(folder).resolve():
            elsewhere = "built in" if known.origin == "built-in" else f"in {Path(known.path).parent}"
        try:
            saved = self.session.save(folder, replace=replace, elsewhere=elsewhere)
        except GestureExists as exc:
            def answer(text: str | None) -> None:
                if text is not None and text.strip().lower() in ("y", "yes", "replace"):
                    self._save(folder, replace=True)
                else:
                    self._show("not saved: choose another name (w)")

            self.app.push_screen(AskScreen("Replace?", f"{exc}. Type yes to replace it."), answer)
            return
        except (FileChanged, DraftError, OutputError) as exc:
            self._show(f"not saved: {exc}")
            return
        self.saved = self.session.draft.to_dict()
        self._edited(True)
        self._show(f"saved {_short(saved.path)}; enter puts [pose:{name}] at the cursor")

    def action_insert(self) -> None:
        if self.saved != self.session.draft.to_dict():
            self._show("save the gesture first (w): the script can only use a saved gesture")
            return
        self.dismiss(pose_tag(self.session.draft.name, 1, False))


def _short(path: Path) -> str:
    """A path as the user reads it: relative to the working folder when it is under it, else the last two parts."""
    path = Path(path)
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(Path(*path.parts[-2:])) if len(path.parts) > 2 else str(path)

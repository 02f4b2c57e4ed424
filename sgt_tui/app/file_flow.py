"""The dialogs around the script file: save (and "save as" when saving fails), reload, changes
on disk, work recovered after a crash, and quitting with unsaved changes.

Nothing here is silent data loss: a save that fails (a read-only folder, a full disk) asks for
another path at once instead of leaving the text only in the recovery file; a file changed on
disk is never overwritten without asking; quitting with unsaved changes asks.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from sgt_tui.app.screens import AskScreen, ChoiceScreen
from sgt_tui.editor.files import ChangedOnDisk, FileError, TargetExists, disk_state, display_name


class FileFlow:
    def __init__(self, app) -> None:
        self.app = app

    @property
    def script(self):
        return self.app.script

    # -- saving -------------------------------------------------------------------------------
    def save(self, *, force: bool = False, then: Callable[[], None] | None = None) -> None:
        """Save; ``then`` runs once the text is safely on disk (under this or another name)."""
        app = self.app
        try:
            self.script.save(force=force)
        except ChangedOnDisk as exc:
            def answer(key: str) -> None:
                if key == "o":
                    self.save(force=True, then=then)
                elif key == "r":
                    self.reload()
                else:
                    app.say("not saved")

            app.push_screen(ChoiceScreen("Changed on disk", f"{exc}.\nOverwrite it with your version, or reload "
                                         "it (your edits stay in undo history)?",
                                         [("o", "overwrite"), ("r", "reload"), ("c", "cancel")]), answer)
            return
        except FileError as exc:
            self.ask_save_as(str(exc), then)
            return
        self._saved(then)

    def ask_save_as(self, why: str = "", then: Callable[[], None] | None = None) -> None:
        """Ask for a path and save there (esc: the text stays in the editor and the recovery file)."""
        app = self.app
        if why:
            app.say(why, "error")
        app.recovery.write()  # whatever happens next, the text is kept

        def answer(target: str | None) -> None:
            if target is None:
                kept = "" if app.recovery.file.problem else f" and in {app.recovery.file.path}"
                app.say(f"not saved; your text is kept in the editor{kept}")
            else:
                self.save_as(Path(target), then=then)

        message = (f"{why}.\n" if why else "") + "Save the script under this name (enter), or esc to keep editing:"
        app.push_screen(AskScreen("Save as", message, str(self.script.path), "path of the script"), answer)

    def save_as(self, target: Path, *, overwrite: bool = False, then: Callable[[], None] | None = None) -> None:
        app = self.app
        try:
            self.script.save_as(target, overwrite=overwrite)
        except TargetExists as exc:
            def answer(key: str) -> None:
                if key == "o":
                    self.save_as(target, overwrite=True, then=then)
                else:
                    self.ask_save_as("", then)

            app.push_screen(ChoiceScreen("Replace it?", f"{exc}. Replace it with this script?",
                                         [("o", "overwrite"), ("c", "choose another name")]), answer)
            return
        except FileError as exc:
            self.ask_save_as(str(exc), then)
            return
        app.recovery.moved(self.script.path)
        app.analyses.retarget(self.script.path)
        self._saved(then)

    def _saved(self, then: Callable[[], None] | None) -> None:
        app = self.app
        app.disk_warned = False
        app.recovery.discard()
        app.say(f"saved {display_name(self.script.path)}")
        app.update_status()
        if then is not None:
            then()

    # -- the file on disk -----------------------------------------------------------------------
    def reload(self) -> None:
        app = self.app
        try:
            text = self.script.read_disk_text()
        except FileError as exc:
            app.say(str(exc), "error")
            return
        with app.doc.group("reload from disk", cursor=app.area.cursor_location):
            app.area.replace(text, (0, 0), app.doc.end)
        app.doc.mark_saved()
        self.script.disk = disk_state(self.script.path)
        app.disk_warned = False
        app.say(f"reloaded {display_name(self.script.path)} from disk (ctrl+z takes it back)")
        app.update_status()

    def disk_changed(self, exists: bool) -> None:
        """Someone else changed the file: reload when nothing is unsaved, else warn (once)."""
        app = self.app
        if not app.doc.modified:
            if exists:
                self.reload()
            return
        if not app.disk_warned:
            app.disk_warned = True
            app.say(f"{display_name(self.script.path)} changed on disk; saving will ask before overwriting", "warning")
            app.update_status()

    def offer_recovery(self, found) -> None:
        app = self.app

        def answer(key: str) -> None:
            if key == "r":
                with app.doc.group("recover unsaved work"):
                    app.area.replace(found.text, (0, 0), app.doc.end)
                app.say("recovered unsaved work (ctrl+s saves it; ctrl+z takes it back)")
            elif key == "d":
                app.recovery.discard()
                app.say("discarded the recovered work")

        n = found.text.count("\n") + 1
        app.push_screen(ChoiceScreen("Recover unsaved work?",
                                     f"Unsaved changes to {display_name(self.script.path)} from {found.age()} "
                                     f"were kept ({n} lines).",
                                     [("r", "recover"), ("d", "discard"), ("l", "later")]), answer)

    # -- leaving ------------------------------------------------------------------------------
    def quit(self) -> None:
        app = self.app
        if not app.doc.modified:
            app.exit(0)
            return

        def answer(key: str) -> None:
            if key == "s":
                self.save(then=lambda: app.exit(0))
            elif key == "q":
                app.recovery.discard()
                app.exit(0)

        app.push_screen(ChoiceScreen("Unsaved changes", f"{display_name(self.script.path)} has unsaved changes.",
                                     [("s", "save and quit"), ("q", "quit without saving"), ("c", "cancel")]), answer)

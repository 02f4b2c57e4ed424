"""``sgt edit``: the terminal authoring app (SGToolkit's loop: sketch, add controls, regenerate).

The application wires the editing model (:mod:`sgt_tui.editor`) and the background services
(:mod:`sgt_tui.app.services`) to thin widgets:

- the document and its one undo history, shown and edited in :class:`ScriptArea`;
- live diagnostics (:class:`AnalysisService` -> :class:`AnalysisReady`), changes on disk
  (:class:`DiskWatcher` -> :class:`DiskChanged`), recovered work (:class:`RecoveryService` ->
  :class:`RecoveryFound`) and jobs (:class:`JobService` -> :class:`JobUpdated`);
- the current utterance (where the cursor is): its timeline and preview (:class:`Takes`);
- the dialogs around the file (:class:`FileFlow`).

Every action is a key (:data:`sgt_tui.app.actions.ACTIONS`, shown in the footer, the keys list
and the command palette). Keys for the editor's screen are handled one at a time, in the order
they came (:meth:`EditorApp.on_event`): an action bound to a key sees every key typed before it
and none typed after it, however fast they arrive.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from textual import events, on
from textual.app import App
from textual.containers import Horizontal, Vertical
from textual.screen import Screen
from textual.widgets import Footer, TextArea
from textual.widgets.text_area import Selection

from core.diagnostics import Diagnostic, summary
from library.words import WordRulesError, load_word_rules
from model.engines import DEFAULT_ENGINE
from sgt_tui.app.actions import ACTION_NAMES, ACTIONS, ENGINE_ORDER, EditorCommands, bindings
from sgt_tui.app.file_flow import FileFlow
from sgt_tui.app.job_flow import JobFlow, weights_exist
from sgt_tui.app.panels import JobBar, MessageLine, PreviewPanel, StatusLine, TimelinePanel
from sgt_tui.app.screens import SEVERITY_MARK, AskScreen, KeysScreen, LibraryScreen, Picked, ProblemsScreen, StyleScreen
from sgt_tui.app.script_area import ScriptArea
from sgt_tui.app.services import (
    AnalysisFailed,
    AnalysisReady,
    AnalysisService,
    BackgroundAnalysis,
    DiskChanged,
    DiskWatcher,
    JobService,
    JobUpdated,
    RecoveryFound,
    RecoveryService,
)
from sgt_tui.editor import edits
from sgt_tui.editor.analysis import Analysis, goto_line
from sgt_tui.editor.files import ScriptFile, display_name
from sgt_tui.editor.player import Player
from sgt_tui.editor.takes import Takes


class MainScreen(Screen):
    """The editor's screen; when a dialog covers it, the preview stops animating."""

    def on_screen_suspend(self) -> None:
        self.app.preview.sync_timer()

    def on_screen_resume(self) -> None:
        self.app.preview.sync_timer()


class EditorApp(App):
    """The ``sgt edit`` application."""

    TITLE = "sgt edit"
    CSS_PATH = "editor.tcss"
    COMMANDS = {EditorCommands}  # the palette lists the editor's actions once (no system duplicates)
    BINDINGS = bindings()

    def __init__(self, script: ScriptFile, *, engine: str | None = None, recovery_dir: Path | None = None,
                 cursor_blink: bool = True, gif_size: tuple[int, int] = (320, 320), weights: str | None = None) -> None:
        super().__init__()
        self.script, self.doc = script, script.document
        self.engine = engine or DEFAULT_ENGINE
        self.gif_size = gif_size
        self.weights = weights  # generator weights for the neural engine (None: the shipped file)
        self.cursor_blink = cursor_blink
        self.analyses = AnalysisService(self, self.doc, script.path)
        self.disk = DiskWatcher(self, script)
        self.recovery = RecoveryService(self, self.doc, script.path, recovery_dir)
        self.jobs = JobService(self)
        self.files = FileFlow(self)
        self.job_flow = JobFlow(self)
        self.takes = Takes()
        self.player = Player()
        self.shown_version = -1  # the version of the text whose diagnostics are on screen
        self.current = None  # UtteranceInfo at the cursor
        self.disk_warned = False
        self.last_message = ""
        self.job_problems: list[Diagnostic] = []  # what the last failed job reported (F2 lists them)
        self.job_text = ""  # the text that job worked on
        self._progress = None  # the timer that shows the first analysis's progress, while it runs

    def check_action(self, action: str, parameters) -> bool | None:
        """The editor's keys act on the main screen only (dialogs have their own keys)."""
        return not (action in ACTION_NAMES and self.screen is not self.screen_stack[0] and action != "quit")

    @property
    def analysis(self) -> Analysis | None:
        return self.analyses.latest

    # -- layout -----------------------------------------------------------------------------
    def get_default_screen(self) -> Screen:
        return MainScreen(id="_default")

    def compose(self):
        yield StatusLine(id="status")
        with Horizontal(id="main"):
            area = ScriptArea(self.doc, id="script")
            area.cursor_blink = self.cursor_blink
            yield area
            with Vertical(id="side"):
                yield PreviewPanel(self.player, id="preview")
        yield TimelinePanel(id="timeline")
        yield MessageLine(id="message")
        bar = JobBar(id="jobbar")
        bar.display = False
        yield bar
        yield Footer(compact=True)

    def on_mount(self) -> None:
        self.area.focus()
        self._fit()
        if self.analyses.inline_first:
            self.analyses.start()
        else:  # a long script: the first screen now, its analysis in the background once it is drawn
            self.preview.empty_message = "analysing…"
            self.timeline.show(None, None, "timeline", "analysing the script…")
            self._progress = self.set_interval(0.5, self.update_status)
            self.call_after_refresh(self.analyses.start)
        self.disk.start()
        self.recovery.start()
        self.update_status()

    # -- keys, in order ----------------------------------------------------------------------------
    async def on_event(self, event: events.Event) -> None:
        """Keys (and pastes) for the editor's own screen are handled here, one at a time, in the
        order they came: the action a key is bound to runs now, a typed character is inserted
        now. (Textual hands a typed character to the text area's queue but runs a priority
        binding at once, and any other binding only after the key has come back up from the
        text area: in a burst from the terminal, ``x`` then ctrl+s saved the text without the
        ``x``, and backspace then ``d`` deleted the ``d``.) Dialogs and anything else: as Textual does."""
        if isinstance(event, (events.Key, events.Paste)) and not event.is_forwarded and self._keys_here():
            if await self._in_order(event):
                return
        await super().on_event(event)

    def _keys_here(self) -> bool:
        return bool(self.screen_stack) and self.screen is self.screen_stack[0]

    async def _in_order(self, event: events.Key | events.Paste) -> bool:
        """Handle a key or a paste for the editor's screen at once; False: leave it to Textual."""
        area = self.focused
        if isinstance(event, events.Paste):
            if not isinstance(area, ScriptArea):
                return False
            area.type_text(event.text, paste=True)
            return True
        self.app_focus = True
        active = self.screen.active_bindings.get(event.key)
        if active is not None and active.enabled:
            return await self.run_action(active.binding.action, active.node)
        if isinstance(area, ScriptArea) and (event.is_printable or event.key == "enter"):
            area.type_text("\n" if event.key == "enter" else event.character or "")
            return True
        return False

    def on_resize(self) -> None:
        self._fit()

    def _fit(self) -> None:
        w, h = self.size
        self._w("#side").styles.width = max(24, min(60, w // 3))
        self.timeline.styles.height = 5 if h < 32 else 7

    @property
    def live(self) -> bool:
        """Whether the editor's screen still has its widgets (messages can arrive while it closes)."""
        return bool(self.screen_stack) and bool(self.screen_stack[0].query(StatusLine))

    def _w(self, selector, expect_type=None):
        """A widget of the editor's own screen (whatever dialog is on top)."""
        return self.screen_stack[0].query_one(selector, expect_type)

    @property
    def area(self) -> ScriptArea:
        return self._w(ScriptArea)

    @property
    def preview(self) -> PreviewPanel:
        return self._w("#preview", PreviewPanel)

    @property
    def timeline(self) -> TimelinePanel:
        return self._w(TimelinePanel)

    def say(self, text: str, severity: str = "information") -> None:
        """A message on the message line; a warning or error also as one notification, whole
        (it replaces the previous one, so they never pile up over the text)."""
        self.last_message = text
        self._w(MessageLine).update(text)
        if severity != "information":
            self.clear_notifications()
            self.notify(text, severity=severity, timeout=8, markup=False)

    # -- analysis, status and the current utterance -----------------------------------------
    @on(TextArea.Changed)
    def _changed(self) -> None:
        self.update_status()
        self.analyses.schedule()

    def on_background_analysis(self, event: BackgroundAnalysis) -> None:
        self.analyses.finished(event)

    def on_analysis_failed(self, event: AnalysisFailed) -> None:
        self.analyses.finished(event)
        if self.live:
            self.say(event.text, "error")

    def ready_analysis(self) -> Analysis | None:
        """The analysis of the text as it is now, for an action; None (and a message saying so)
        while a long script's first analysis is still running."""
        found = self.analyses.now()
        if found is None:
            self.say(f"still analysing the script ({self.analyses.progress:.0%}); try again in a moment")
        return found

    def on_analysis_ready(self, event: AnalysisReady) -> None:
        if event.version != self.doc.version or not self.live:
            return  # a newer change is on its way, or the editor is closing
        self.area.set_diagnostics({line - 1: found for line, found in event.analysis.by_line.items() if line > 0})
        self.shown_version = event.version
        if self._progress is not None:
            self._progress.stop()
            self._progress = None
        self.update_status()
        self.update_cursor_info(force=True)

    def update_status(self) -> None:
        a = self.analysis
        name = display_name(self.script.path)
        if len(name) > 32:  # keep room for the rest of the line
            name = "…/" + self.script.path.name
            if len(name) > 40:  # a very long file name: its start and its end
                name = name[:20] + "…" + name[-19:]
        parts = [name + (" [+]" if self.doc.modified else "") + (" (new)" if self.script.is_new else "")]
        if a is None and not self.analyses.inline_first:
            parts.append(f"analysing… {self.analyses.progress:.0%}")
        elif a is not None:
            parts.append(summary(a.diagnostics) if a.diagnostics else "ok")
            if self.current is not None and a.utterances:
                parts.append(f"utt {self.current.index + 1}/{len(a.utterances)}")
        parts.append(f"engine {self.engine}" + ("" if weights_exist(self.weights) or self.engine != "neural"
                                                  else " (no weights)"))
        if self.disk_warned:
            parts.append("CHANGED ON DISK")
        if self.recovery.told:
            parts.append("NO CRASH RECOVERY")
        self._w(StatusLine).update(" │ ".join(parts))

    @on(TextArea.SelectionChanged)
    def _selection(self) -> None:
        self.update_cursor_info()

    def update_cursor_info(self, force: bool = False) -> None:
        a = self.analysis
        if a is None:
            return
        row, col = self.area.cursor_location
        found = a.at(row + 1, col + 1)
        if found:
            d = found[0]
            more = f" (+{len(found) - 1} more)" if len(found) > 1 else ""
            hint = f" · {d.hint}" if d.hint else ""
            fix = f" · ^f: {d.fixes[0].title}" if d.fixes else ""
            self._w(MessageLine).update(
                f"{SEVERITY_MARK.get(d.severity, '?')} {d.severity} {d.line}:{d.col}: {d.message}{hint}{fix}{more}")
        else:
            self._w(MessageLine).update(self.last_message)
        info = a.utterance_at(row + 1)
        old = self.current
        if force or info is None or old is None or (info.index, info.key) != (old.index, old.key):
            self.current = info
            self.show_utterance(restart=getattr(old, "index", None) != getattr(info, "index", None))
            self.update_status()

    @property
    def current_key(self) -> str | None:
        return self.current.key if self.current is not None else None

    def show_utterance(self, restart: bool = False) -> None:
        """Timeline and preview of the current utterance: generated motion, else a draft."""
        view = self.takes.view(self.current)
        self.player.load(view.positions, view.label, keep_frame=not restart)
        self.preview.empty_message = view.no_motion
        self.timeline.show(view.timeline, self.player.frame if view.timeline else None, view.title, view.no_timeline)
        self.preview.sync_timer()
        self.preview.refresh()

    @on(PreviewPanel.FrameChanged)
    def _frame(self) -> None:
        self.timeline.set_playhead(self.player.frame if self.player.n_frames else None)

    @on(TimelinePanel.Scrub)
    def _scrub(self, event: TimelinePanel.Scrub) -> None:
        self.preview.action_step(event.frames)

    @on(TimelinePanel.Toggle)
    def _toggle(self) -> None:
        self.action_play()

    # -- editing actions --------------------------------------------------------------------
    def apply_action(self, make) -> None:
        """Make an action's replacements through the text area, one undo step; ``make`` returns
        the :class:`~sgt_tui.editor.edits.Action` or raises EditRefused (its message is shown)."""
        try:
            action = make()
        except edits.EditRefused as exc:
            self.say(str(exc))
            return
        area = self.area
        with self.doc.group(action.label, cursor=area.cursor_location):
            for r in action.replacements:
                area.replace(r.text, r.start, r.end)
        if action.selection is not None:
            area.selection = Selection(*action.selection)
        elif action.cursor is not None:
            area.move_cursor(action.cursor)
        if action.message:
            self.say(action.message)

    def action_undo(self) -> None:
        self._history(self.doc.undo, "undo", "undid", self.doc.redo_label)

    def action_redo(self) -> None:
        self._history(self.doc.redo, "redo", "redid", self.doc.undo_label)

    def _history(self, step, verb: str, past: str, label) -> None:
        done = step()
        if done is None:
            self.say(f"nothing to {verb}")
            return
        self.area.mirror(*done)
        self.say(f"{past} {label()}")

    def action_move_pose(self, step: int) -> None:
        cursor = self.area.cursor_location
        a = self.ready_analysis()
        if a is None:
            return
        info = a.utterance_at(cursor[0] + 1)
        self.apply_action(lambda: edits.move_pose(self.doc, cursor, step, info.word_spans() if info else []))

    def insert_pose(self, tag: str | None) -> None:
        if tag:
            self.apply_action(lambda: edits.insert_pose(self.doc, self.area.cursor_location, tag))

    def action_library(self) -> None:
        a = self.ready_analysis()
        if a is None:
            return
        if a.library is None or not len(a.library):
            self.say("the motion library is empty", "warning")
            return
        self.push_screen(LibraryScreen(a.library), self.insert_pose)

    def action_style(self) -> None:
        a = self.ready_analysis()
        if a is None:
            return
        start, end = self.area.selection
        try:
            target = edits.style_target(self.doc, start, end)
        except edits.EditRefused as exc:
            self.say(str(exc))
            return

        def done(answer) -> None:
            if answer:
                self.apply_style(answer.get("values"), answer.get("preset"), (start, end))

        self.push_screen(StyleScreen(self.doc.get_range(*target), a.header.presets if a.header else {}), done)

    def apply_style(self, values: dict | None, preset: str | None, selection=None) -> None:
        start, end = selection or self.area.selection
        self.apply_action(lambda: edits.apply_style(self.doc, start, end, values=values, preset=preset))

    # -- problems and navigation ------------------------------------------------------------------
    def problems(self) -> list[Diagnostic] | None:
        """Every problem: the live analysis's, then those the last failed job reported (real
        speech timing finds some the estimate cannot), without repeats; None (and a message)
        while the first analysis is running."""
        a = self.ready_analysis()
        if a is None:
            return None
        found = list(a.diagnostics)
        seen = {(d.line, d.col, d.message) for d in found}
        stale = self.job_text != self.doc.text  # their fixes were made for another text
        return found + [dataclasses.replace(d, fixes=()) if stale else d
                        for d in self.job_problems if (d.line, d.col, d.message) not in seen]

    def action_problems(self) -> None:
        def picked(answer: Picked | None) -> None:
            if answer is not None:
                self.goto(answer.diagnostic)
                if answer.fix is not None:
                    self.apply_action(lambda: edits.apply_fix(self.doc, answer.fix))

        found = self.problems()
        if found is not None:
            self.push_screen(ProblemsScreen(found), picked)

    def goto(self, d: Diagnostic) -> None:
        if d.file == str(self.script.path) and d.line > 0:
            self.area.move_cursor((d.line - 1, max(0, d.col - 1)))
            self.area.focus()
        else:
            self.say(f"{d.file}: {d.message}" if d.file != str(self.script.path) else d.message)

    def action_next_problem(self) -> None:
        found = self.problems()
        if found is None:
            return
        mine = [d for d in found if d.file == str(self.script.path) and d.line > 0]
        if not mine:
            self.say("no problems")
            return
        row, col = self.area.cursor_location
        after = [d for d in mine if (d.line - 1, d.col - 1) > (row, col)]
        self.goto((after or mine)[0])

    def action_quick_fix(self) -> None:
        """Apply the first suggested fix of the problem at the cursor (else on its line)."""
        row, col = self.area.cursor_location
        a = self.ready_analysis()
        if a is None:
            return
        fixable = [d for d in a.at(row + 1, col + 1) if d.fixes]
        if not fixable:
            self.say("no suggested fix here (F2 lists every problem and its fixes)")
            return
        self.apply_action(lambda: edits.apply_fix(self.doc, fixable[0].fixes[0]))

    def action_suggest(self) -> None:
        """The gestures the words of the utterance at the cursor call for (``sgt suggest``)."""
        a = self.ready_analysis()
        if a is None:
            return
        if a.library is None:
            self.say("the motion library is not loaded (see F2)", "warning")
            return
        try:
            rules = load_word_rules(folder for origin, folder in a.library.folders if origin != "built-in")
        except WordRulesError as exc:
            self.say(str(exc), "error")
            return
        info = a.utterance_at(self.area.cursor_location[0] + 1)
        self.apply_action(lambda: edits.suggest_gestures(self.doc, info, a.library, rules))

    def action_goto(self, start: str = "") -> None:
        def answer(text: str | None) -> None:
            if text is None:
                return
            try:
                line = goto_line(text, self.analyses.now(), len(self.doc.lines))
            except ValueError as exc:
                self.say(str(exc))
                return
            self.area.move_cursor((line - 1, 0))
            self.area.scroll_cursor_visible(center=True)

        self.push_screen(AskScreen("Go to", "A line number (12), or u and an utterance number (u3):", start,
                                   "12 or u3"), answer)

    def action_keys(self) -> None:
        self.push_screen(KeysScreen([(a.key, a.title, a.help) for a in ACTIONS]))

    def action_play(self) -> None:
        if not self.player.n_frames:
            self.say("nothing to play yet: write an utterance")
            return
        self.preview.play()

    # -- files (the dialogs are in FileFlow) ------------------------------------------------------
    def action_save(self) -> None:
        self.files.save()

    def action_save_as(self) -> None:
        self.files.ask_save_as()

    def on_disk_changed(self, event: DiskChanged) -> None:
        if self.live:
            self.files.disk_changed(event.exists)

    def on_recovery_found(self, event: RecoveryFound) -> None:
        if self.live:
            self.files.offer_recovery(event.found)

    def action_quit(self) -> None:
        self.files.quit()

    def on_unmount(self) -> None:
        self.analyses.close()
        self.jobs.shutdown()

    # -- jobs (shown by JobFlow) ------------------------------------------------------------------
    def action_job(self, op: str, whole: bool) -> None:
        self.job_flow.start(op, whole)

    def action_cancel_job(self) -> None:
        self.job_flow.cancel()

    def on_job_updated(self, event: JobUpdated) -> None:
        if self.live:
            self.job_flow.updated(event.job)

    def action_next_engine(self) -> None:
        i = ENGINE_ORDER.index(self.engine) if self.engine in ENGINE_ORDER else -1
        self.set_engine(ENGINE_ORDER[(i + 1) % len(ENGINE_ORDER)])

    def set_engine(self, name: str) -> None:
        self.engine = name
        note = ""
        if name == "neural" and not weights_exist(self.weights):
            note = ": its weights are missing (model/weights/generator.pt); run 'sgt train' or pick keyframe or rules"
        self.say(f"engine {name}{note}", "warning" if note else "information")
        self.update_status()



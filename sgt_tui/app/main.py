"""``sgt edit``: the terminal authoring app (SGToolkit's loop: sketch, add controls, regenerate).

The application wires the editing model (:mod:`sgt_tui.editor`) to thin widgets:

- the document and its one undo history, the script file (atomic saves, changes on disk) and
  the recovery file;
- live diagnostics: every change schedules an analysis (debounced, in a thread, incremental);
- the current utterance (where the cursor is): its timeline and motion preview;
- jobs (generate, render a GIF) in a worker subprocess, with a progress bar and cancel.

Every action is a key (see :data:`ACTIONS`, shown in the footer, the keys list and the command
palette). Keys avoid ctrl+shift combinations and keys terminals or tmux take for themselves.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path

from textual import on
from textual.app import App, SystemCommand
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.message import Message
from textual.screen import Screen
from textual.widgets import Footer, TextArea

from core.diagnostics import summary
from core.motion import MotionFileError, load_motion
from core.skeleton import FPS, positions_from_pose
from model import keyframe
from model.generate import EngineInputs
from model.weights import DEFAULT_WEIGHTS
from sgt_tui.app.panels import JobBar, MessageLine, PreviewPanel, StatusLine, TimelinePanel
from sgt_tui.app.screens import SEVERITY_MARK, ChoiceScreen, KeysScreen, LibraryScreen, ProblemsScreen, StyleScreen
from sgt_tui.app.script_area import ScriptArea
from sgt_tui.editor import edits
from sgt_tui.editor.analysis import Analyser, Analysis
from sgt_tui.editor.files import ChangedOnDisk, FileError, ScriptFile, disk_state, display_name
from sgt_tui.editor.jobs import CANCELLED, DONE, FAILED, Job, JobRunner
from sgt_tui.editor.player import Player
from sgt_tui.editor.recovery import INTERVAL, RecoveryFile, editor_cache_dir
from sgt_tui.editor.timeline import from_clip, from_plan

ANALYSIS_DELAY = 0.08  # seconds of quiet typing before the diagnostics are refreshed
QUICK_ANALYSIS = 0.03  # an analysis faster than this (seconds) runs on the interface thread
DISK_CHECK = 2.0  # seconds between checks for changes on disk
ENGINE_ORDER = ("neural", "keyframe", "rules")


@dataclass(frozen=True)
class Act:
    key: str
    action: str
    footer: str  # short label in the footer ("" = not in the footer)
    title: str  # command palette title
    help: str


ACTIONS: tuple[Act, ...] = (
    Act("ctrl+s", "save", "save", "Save", "write the script (atomically; asks if it changed on disk)"),
    Act("ctrl+z", "undo", "undo", "Undo", "take back the last change, typed or made by an action"),
    Act("ctrl+y", "redo", "", "Redo", "make the undone change again"),
    Act("f1", "keys", "keys", "Keys", "list every key"),
    Act("f2", "problems", "probs", "Problems", "list every problem; enter jumps to it"),
    Act("ctrl+n", "next_problem", "", "Next problem", "jump to the next problem after the cursor"),
    Act("f3", "library", "lib", "Motion library", "browse gestures with a live preview; insert one at the cursor"),
    Act("f4", "style", "style", "Style the selection", "speed, space, handedness or a preset for the selected words"),
    Act("alt+left", "move_pose(-1)", "", "Pose to previous word", "move the pose control at the cursor to the previous word"),
    Act("alt+right", "move_pose(1)", "", "Pose to next word", "move the pose control at the cursor to the next word"),
    Act("f5", "play", "play", "Play / pause", "play or pause the motion preview (15 fps)"),
    Act("ctrl+g", "generate", "gen", "Generate utterance", "generate motion for the utterance at the cursor"),
    Act("f8", "generate_all", "", "Generate script", "generate motion for the whole script"),
    Act("f9", "render", "gif", "Render GIF of utterance", "render the utterance at the cursor to a GIF"),
    Act("ctrl+r", "render_all", "", "Render GIF of script", "render the whole script to a GIF"),
    Act("ctrl+t", "cancel_job", "", "Cancel job", "stop the running generate or render job"),
    Act("ctrl+o", "next_engine", "", "Next engine", "switch the generation engine: neural, keyframe, rules"),
    Act("ctrl+q", "quit", "quit", "Quit", "leave the editor (asks about unsaved changes)"),
    Act("ctrl+p", "command_palette", "", "Command palette", "search every action by name"),
)
#: Footer order (the most used first; everything else is in F1 and the palette).
FOOTER_ORDER = ("ctrl+s", "ctrl+z", "f1", "f2", "f3", "f4", "f5", "ctrl+g", "f9", "ctrl+q")


class MainScreen(Screen):
    """The editor's screen; when a dialog covers it, the preview stops animating."""

    def on_screen_suspend(self) -> None:
        self.app.preview.sync_timer()

    def on_screen_resume(self) -> None:
        self.app.preview.sync_timer()


class JobUpdate(Message):
    def __init__(self, job: Job) -> None:
        super().__init__()
        self.job = job


class EditorApp(App):
    """The ``sgt edit`` application."""

    TITLE = "sgt edit"
    CSS_PATH = "editor.tcss"
    ENABLE_COMMAND_PALETTE = True
    BINDINGS = [Binding(a.key, a.action, a.footer or a.title, show=bool(a.footer),
                        priority=True)
                for a in sorted(ACTIONS, key=lambda a: FOOTER_ORDER.index(a.key) if a.key in FOOTER_ORDER else 99)
                if a.action != "command_palette"]

    def __init__(self, script: ScriptFile, *, engine: str | None = None, recovery_dir: Path | None = None,
                 cursor_blink: bool = True, gif_size: tuple[int, int] = (320, 320), weights: str | None = None) -> None:
        super().__init__()
        self.script = script
        self.doc = script.document
        self.engine = engine or "neural"
        self.gif_size = gif_size
        self.weights = weights  # generator weights for the neural engine (None: the shipped file)
        self.analyser = Analyser(script.path)
        self.analysis: Analysis | None = None
        self.analysed_version = -1
        self._analysis_lock = threading.Lock()
        self._analysis_timer = None
        self._analysis_seconds = 1.0  # how long the last analysis took
        self.recovery = RecoveryFile(script.path, recovery_dir)
        self.player = Player()
        self.generated: dict[str, tuple[str, object]] = {}  # utterance key -> (engine, MotionClip)
        self._drafts: dict[str, object] = {}  # utterance key -> positions from the keyframe engine
        self.current_key: str | None = None
        self.current_index: int | None = None
        self.disk_warned = False
        self.cursor_blink = cursor_blink
        self.runner = JobRunner(lambda job: self.post_message(JobUpdate(job)),
                                log_path=editor_cache_dir() / "worker.log")
        self.last_message = ""

    def check_action(self, action: str, parameters) -> bool | None:
        """The editor's keys act on the main screen only (dialogs have their own keys)."""
        if action in _ACTION_NAMES and self.screen is not self.screen_stack[0] and action != "quit":
            return False
        return True

    # -- layout -----------------------------------------------------------------------------
    def get_default_screen(self) -> Screen:
        return MainScreen(id="_default")

    def compose(self):
        yield StatusLine("", id="status")
        with Horizontal(id="main"):
            area = ScriptArea(self.doc, id="script")
            area.cursor_blink = self.cursor_blink
            yield area
            with Vertical(id="side"):
                yield PreviewPanel(self.player, id="preview")
        yield TimelinePanel(id="timeline")
        yield MessageLine("", id="message")
        bar = JobBar(id="jobbar")
        bar.display = False
        yield bar
        yield Footer(compact=True, show_command_palette=False)

    def on_mount(self) -> None:
        self.area.focus()
        self._fit()
        self.run_analysis_now()
        self.set_interval(DISK_CHECK, self.check_disk)
        self.set_interval(INTERVAL, self.write_recovery)
        self.update_status()
        self.call_after_refresh(self.offer_recovery)

    def on_resize(self) -> None:
        self._fit()

    def _fit(self) -> None:
        w, h = self.size
        self._w("#side").styles.width = max(24, min(60, w // 3))
        self.timeline.styles.height = 5 if h < 32 else 7

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
        """A short message on the message line (and as a notification when it matters)."""
        self.last_message = text
        self._w(MessageLine).update(text)
        if severity != "information":
            self.notify(text, severity=severity, timeout=8)

    # -- analysis ---------------------------------------------------------------------------
    @on(TextArea.Changed)
    def _changed(self) -> None:
        self.update_status()
        if self._analysis_timer is not None:
            self._analysis_timer.stop()
        self._analysis_timer = self.set_timer(ANALYSIS_DELAY, self._start_analysis)

    def _start_analysis(self) -> None:
        self._analysis_timer = None
        if not self.screen_stack:  # shutting down
            return
        if self._analysis_seconds < QUICK_ANALYSIS:  # cheaper than handing it to a thread
            self.run_analysis_now()
        else:
            self.run_worker(self._analyse_in_thread, thread=True, group="analysis", exclusive=False)

    def _analyse_in_thread(self) -> None:
        with self._analysis_lock:
            version, text = self.doc.version, self.doc.text
            if version == self.analysed_version:
                return
            result = self._timed_run(text)
        self.call_from_thread(self.apply_analysis, result, version)

    def _timed_run(self, text: str) -> Analysis:
        t = time.perf_counter()
        result = self.analyser.run(text)
        self._analysis_seconds = time.perf_counter() - t
        return result

    def run_analysis_now(self) -> Analysis:
        """Analyse on this thread when the analysis is stale (before an action needs it)."""
        with self._analysis_lock:
            if self.analysed_version != self.doc.version or self.analysis is None:
                self.apply_analysis(self._timed_run(self.doc.text), self.doc.version)
        return self.analysis

    def apply_analysis(self, analysis: Analysis, version: int) -> None:
        if version != self.doc.version or not self.screen_stack:
            return  # a newer change is on its way
        self.analysis, self.analysed_version = analysis, version
        by_row: dict[int, list] = {}
        for line, found in analysis.by_line.items():
            if line > 0:
                by_row[line - 1] = found
        self.area.set_diagnostics(by_row)
        self.update_status()
        self.update_cursor_info(force=True)

    # -- status and the current utterance ---------------------------------------------------
    def update_status(self) -> None:
        a = self.analysis
        name = display_name(self.script.path)
        if len(name) > 32:  # keep room for the rest of the line
            name = "…/" + self.script.path.name
        parts = [name + (" [+]" if self.doc.modified else "") + (" (new)" if self.script.is_new else "")]
        if a is not None:
            parts.append(summary(a.diagnostics) if a.diagnostics else "ok")
            if self.current_index is not None and a.utterances:
                parts.append(f"utt {self.current_index + 1}/{len(a.utterances)}")
        engine = self.engine
        if engine == "neural" and not _weights_exist(self.weights):
            engine += " (no weights)"
        parts.append(f"engine {engine}")
        if self.disk_warned:
            parts.append("CHANGED ON DISK")
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
            self._w(MessageLine).update(
                f"{SEVERITY_MARK.get(d.severity, '?')} {d.severity} {d.line}:{d.col}: {d.message}{hint}{more}")
        else:
            self._w(MessageLine).update(self.last_message)
        info = a.utterance_at(row + 1)
        index = info.index if info else None
        key = info.key if info else None
        if force or index != self.current_index or key != self.current_key:
            changed_utterance = index != self.current_index
            self.current_index, self.current_key = index, key
            self.show_utterance(info, restart=changed_utterance)
            self.update_status()

    def show_utterance(self, info, restart: bool = False) -> None:
        """Timeline and preview of the current utterance: generated motion, else a draft."""
        preview, timeline = self.preview, self.timeline
        if info is None:
            self.player.load(None, "")
            preview.empty_message = "write an utterance to see it move"
            timeline.show(None, None, "timeline", "no utterance yet: type one, e.g.  guide: Hello! [pose:wave]")
            preview.sync_timer()
            preview.refresh()
            return
        title = f"utterance {info.index + 1} (line {info.line})"
        found = self.generated.get(info.key)
        if found is not None:
            engine, clip = found
            self.player.load(clip.positions, f"generated · {engine}", keep_frame=not restart)
            data = from_clip(clip, timing="speech")
            timeline.show(data, self.player.frame, f"{title} · {data.duration:.1f} s · speech timing")
        elif info.plan is not None:
            positions = self._draft(info)
            self.player.load(positions, "draft · ^g generates", keep_frame=not restart)
            data = from_plan(info.plan)
            timeline.show(data, self.player.frame, f"{title} · {data.duration:.1f} s · estimated timing")
        else:
            self.player.load(None, "")
            preview.empty_message = "fix errors to preview"
            timeline.show(None, None, title, f"utterance {info.index + 1} has errors: fix them to see its timeline")
        preview.sync_timer()
        preview.refresh()

    def _draft(self, info):
        hit = self._drafts.get(info.key)
        if hit is None:
            hit = positions_from_pose(keyframe.generate(EngineInputs.from_plan(info.plan)))
            if len(self._drafts) > 256:
                self._drafts.clear()
            self._drafts[info.key] = hit
        return hit

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
    def apply_action(self, action: edits.Action) -> None:
        """Make an action's replacements through the text area: one undo step."""
        area = self.area
        with self.doc.group(action.label, cursor=area.cursor_location):
            for r in action.replacements:
                area.replace(r.text, r.start, r.end)
        if action.selection is not None:
            from textual.widgets.text_area import Selection

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
        a = self.run_analysis_now()
        row, col = self.area.cursor_location
        info = a.utterance_at(row + 1)
        try:
            act = edits.move_pose(self.doc, (row, col), step, info.word_spans() if info else [])
        except edits.EditRefused as exc:
            self.say(str(exc))
            return
        self.apply_action(act)

    def insert_pose(self, tag: str | None) -> None:
        if not tag:
            return
        try:
            act = edits.insert_pose(self.doc, self.area.cursor_location, tag)
        except edits.EditRefused as exc:
            self.say(str(exc))
            return
        self.apply_action(act)

    def action_library(self) -> None:
        a = self.run_analysis_now()
        if a.library is None or not len(a.library):
            self.say("the motion library is empty", "warning")
            return
        self.push_screen(LibraryScreen(a.library), self.insert_pose)

    def action_style(self) -> None:
        a = self.run_analysis_now()
        start, end = self.area.selection
        try:
            target = edits.style_target(self.doc, start, end)
        except edits.EditRefused as exc:
            self.say(str(exc))
            return
        selected = self.doc.get_range(*target)
        presets = a.header.presets if a.header is not None else {}

        def done(answer) -> None:
            if not answer:
                return
            self.apply_style(answer.get("values"), answer.get("preset"), (start, end))

        self.push_screen(StyleScreen(selected, presets), done)

    def apply_style(self, values: dict | None, preset: str | None, selection=None) -> None:
        start, end = selection or self.area.selection
        try:
            act = edits.apply_style(self.doc, start, end, values=values, preset=preset)
        except edits.EditRefused as exc:
            self.say(str(exc))
            return
        self.apply_action(act)

    def action_problems(self) -> None:
        a = self.run_analysis_now()

        def jump(d) -> None:
            if d is not None:
                self.goto(d)

        self.push_screen(ProblemsScreen(list(a.diagnostics)), jump)

    def goto(self, d) -> None:
        if d.file == str(self.script.path) and d.line > 0:
            self.area.move_cursor((d.line - 1, max(0, d.col - 1)))
            self.area.focus()
        else:
            self.say(f"{d.file}: {d.message}")

    def action_next_problem(self) -> None:
        a = self.run_analysis_now()
        mine = [d for d in a.diagnostics if d.file == str(self.script.path) and d.line > 0]
        if not mine:
            self.say("no problems")
            return
        row, col = self.area.cursor_location
        after = [d for d in mine if (d.line - 1, d.col - 1) > (row, col)]
        self.goto((after or mine)[0])

    def action_keys(self) -> None:
        self.push_screen(KeysScreen([(a.key, a.title, a.help) for a in ACTIONS]))

    def action_play(self) -> None:
        if not self.player.n_frames:
            self.say("nothing to play yet: write an utterance")
            return
        self.preview.play()

    # -- files --------------------------------------------------------------------------------
    def action_save(self, force: bool = False) -> None:
        try:
            self.script.save(force=force)
        except ChangedOnDisk as exc:
            def answer(key: str) -> None:
                if key == "o":
                    self.action_save(force=True)
                elif key == "r":
                    self.reload_from_disk()
                else:
                    self.say("not saved")

            self.push_screen(ChoiceScreen("Changed on disk", f"{exc}.\nOverwrite it with your version, or reload "
                                          "it (your edits stay in undo history)?",
                                          [("o", "overwrite"), ("r", "reload"), ("c", "cancel")]), answer)
            return
        except FileError as exc:
            self.say(str(exc), "error")
            return
        self.disk_warned = False
        self.recovery.discard()
        self.say(f"saved {display_name(self.script.path)}")
        self.update_status()

    def reload_from_disk(self) -> None:
        try:
            text = self.script.read_disk_text()
        except FileError as exc:
            self.say(str(exc), "error")
            return
        with self.doc.group("reload from disk", cursor=self.area.cursor_location):
            self.area.replace(text, (0, 0), self.doc.end)
        self.doc.mark_saved()
        self.script.disk = disk_state(self.script.path)
        self.disk_warned = False
        self.say(f"reloaded {display_name(self.script.path)} from disk (ctrl+z takes it back)")
        self.update_status()

    def check_disk(self) -> None:
        if not self.script.changed_on_disk():
            return
        if not self.doc.modified:
            if self.script.path.exists():
                self.reload_from_disk()
            return
        if not self.disk_warned:
            self.disk_warned = True
            self.say(f"{display_name(self.script.path)} changed on disk; saving will ask before overwriting", "warning")
            self.update_status()

    def write_recovery(self) -> None:
        self.recovery.update(self.doc.text, self.doc.version, self.doc.modified)

    def offer_recovery(self) -> None:
        found = self.recovery.load()
        if found is None:
            return
        if found.text == self.doc.text:
            self.recovery.discard()
            return

        def answer(key: str) -> None:
            if key == "r":
                with self.doc.group("recover unsaved work"):
                    self.area.replace(found.text, (0, 0), self.doc.end)
                self.say("recovered unsaved work (ctrl+s saves it; ctrl+z takes it back)")
            elif key == "d":
                self.recovery.discard()
                self.say("discarded the recovered work")

        n = found.text.count("\n") + 1
        self.push_screen(ChoiceScreen("Recover unsaved work?",
                                      f"Unsaved changes to {display_name(self.script.path)} from {found.age()} "
                                      f"were kept ({n} lines).",
                                      [("r", "recover"), ("d", "discard"), ("l", "later")]), answer)

    def action_quit(self) -> None:
        if not self.doc.modified:
            self.exit(0)
            return

        def answer(key: str) -> None:
            if key == "s":
                self.action_save()
                if not self.doc.modified:
                    self.exit(0)
            elif key == "q":
                self.recovery.discard()
                self.exit(0)

        self.push_screen(ChoiceScreen("Unsaved changes", f"{display_name(self.script.path)} has unsaved changes.",
                                      [("s", "save and quit"), ("q", "quit without saving"), ("c", "cancel")]), answer)

    def on_unmount(self) -> None:
        self.runner.shutdown()

    # -- jobs -----------------------------------------------------------------------------------
    def _job(self, op: str, whole: bool) -> None:
        a = self.run_analysis_now()
        if not a.utterances:
            self.say("nothing to generate: the script has no utterances")
            return
        row = self.area.cursor_location[0]
        info = a.utterance_at(row + 1)
        if whole:
            bad = [u for u in a.utterances if u.errors]
        else:
            bad = [info] if info.errors else []
        if bad:
            self.say(f"utterance {bad[0].index + 1} has errors: fix them first (F2 lists problems)", "warning")
            return
        keys = [u.key for u in a.utterances]
        cache = editor_cache_dir() / "motion"
        request = dict(path=str(self.script.path), source=self.doc.text, engine=self.engine, weights=self.weights,
                       utterances=None if whole else [info.index], keys=keys,
                       out=str(cache / f"{_take_name(self.script.path, 'all' if whole else info.key)}-{self.engine}.npz"))
        what = "script" if whole else f"utterance {info.index + 1}"
        if op == "render":
            stem = self.script.path.stem
            gif = self.script.path.with_name(f"{stem}.gif" if whole else f"{stem}.u{info.index}.gif")
            request.update(gif=str(gif), size=list(self.gif_size))
            label = f"gif {what}"
        else:
            label = f"generate {what}"
        self.runner.submit(op, f"{label} ({self.engine})", **request)

    def action_generate(self) -> None:
        self._job("generate", whole=False)

    def action_generate_all(self) -> None:
        self._job("generate", whole=True)

    def action_render(self) -> None:
        self._job("render", whole=False)

    def action_render_all(self) -> None:
        self._job("render", whole=True)

    def action_cancel_job(self) -> None:
        job = self.runner.cancel()
        if job is None:
            self.say("no job is running")

    def action_next_engine(self) -> None:
        i = ENGINE_ORDER.index(self.engine) if self.engine in ENGINE_ORDER else -1
        self.set_engine(ENGINE_ORDER[(i + 1) % len(ENGINE_ORDER)])

    def set_engine(self, name: str) -> None:
        self.engine = name
        note = ""
        if name == "neural" and not _weights_exist(self.weights):
            note = ": its weights are missing (model/weights/generator.pt); run 'sgt train' or pick keyframe or rules"
        self.say(f"engine {name}{note}", "warning" if note else "information")
        self.update_status()

    def on_job_update(self, event: JobUpdate) -> None:
        job = event.job
        bar = self._w(JobBar)
        if not job.finished_state:
            waiting = f" (+{len(self.runner.queue)} queued)" if self.runner.queue else ""
            bar.show_job(job.label + waiting, job.fraction, job.phase if job.state == "running" else "queued")
            return
        if not self.runner.busy:
            bar.display = False
        if job.state == DONE:
            self._job_done(job)
        elif job.state == FAILED:
            extra = " (F2 lists the problems)" if job.diagnostics else ""
            self.say(f"{job.label} failed: {job.message}{extra}", "error")
        elif job.state == CANCELLED:
            self.say(f"{job.label}: cancelled")

    def _job_done(self, job: Job) -> None:
        result = job.result or {}
        keys = job.request.get("keys") or []
        try:
            clips = load_motion(result["motion"]) if result.get("motion") else []
        except (MotionFileError, OSError, KeyError) as exc:
            self.say(f"{job.label}: cannot read the motion: {exc}", "error")
            return
        for clip, index in zip(clips, result.get("utterances", [])):
            if 0 <= index < len(keys):
                self.generated[keys[index]] = (job.request.get("engine"), clip)
        if len(self.generated) > 256:
            for k in list(self.generated)[:-256]:
                del self.generated[k]
        if job.op == "render":
            self.say(f"wrote {display_name(Path(result.get('gif', '')))} ({result.get('gif_frames', 0)} frames)", "information")
            self.notify(f"wrote {result.get('gif')}", timeout=6)
        else:
            secs = result.get("frames", 0) / FPS
            self.say(f"{job.label}: done, {secs:.1f} s of motion")
        info = self.analysis.utterance_at(self.area.cursor_location[0] + 1) if self.analysis else None
        if info is not None and info.key in self.generated:
            self.show_utterance(info, restart=True)
            self.preview.play(True)

    # -- command palette ------------------------------------------------------------------------
    def get_system_commands(self, screen):
        for a in ACTIONS:
            if a.action == "command_palette":
                continue
            name, _, arg = a.action.partition("(")
            method = getattr(self, f"action_{name}")
            callback = (lambda m=method, v=int(arg.rstrip(")")): m(v)) if arg else method
            yield SystemCommand(f"{a.title}  [{a.key}]", a.help, callback)
        for name in ENGINE_ORDER:
            yield SystemCommand(f"Engine: {name}", f"generate with the {name} engine", lambda n=name: self.set_engine(n))
        for preset in ("happy", "sad", "angry", "calm"):
            yield SystemCommand(f"Style preset: {preset}", f"wrap the selected words in <{preset}>",
                                lambda p=preset: self.apply_style(None, p))
        yield from super().get_system_commands(screen)


def _take_name(script: Path, what: str) -> str:
    """A cache file name for generated motion: one per script and utterance text (or 'all')."""
    import hashlib

    return hashlib.sha1(f"{script.resolve()}|{what}".encode("utf-8")).hexdigest()[:20]


_ACTION_NAMES = {a.action.partition("(")[0] for a in ACTIONS} - {"command_palette"}


def _weights_exist(path: str | None = None) -> bool:
    return Path(path).exists() if path else DEFAULT_WEIGHTS.exists()

"""The editor's background services: live analysis, disk watching, recovery and jobs.

Each service owns one concern and its timing (Textual workers, timers, a subprocess) and tells
the application what happened with a typed message; the application only shows it:

- :class:`AnalysisService` analyses each new version of the text after a short pause in typing,
  in a Textual worker of the exclusive group ``"analysis"`` (a newer keystroke cancels the
  pending one); a slow analysis (a long script's first) runs on a background thread, one at a
  time, while the screen is drawn and editing goes on -> :class:`AnalysisReady`;
- :class:`DiskWatcher` checks the script on disk every few seconds (a thread worker of the
  exclusive group ``"disk"``) -> :class:`DiskChanged`;
- :class:`RecoveryService` writes unsaved work to the recovery file every few seconds and finds
  work left by a crash -> :class:`RecoveryFound`;
- :class:`JobService` runs generate/render jobs in the worker process -> :class:`JobUpdated`.
"""

from __future__ import annotations

import asyncio
import threading
import time
from pathlib import Path

from textual.app import App
from textual.message import Message

from sgt_tui.editor.analysis import Analyser, Analysis, Stopped
from sgt_tui.editor.document import Document
from sgt_tui.editor.files import ScriptFile
from sgt_tui.editor.jobs import Job, JobPlan, JobRunner
from sgt_tui.editor.recovery import INTERVAL, Recovered, RecoveryFile, editor_cache_dir

ANALYSIS_DELAY = 0.08  # seconds of quiet typing before the diagnostics are refreshed
QUICK_ANALYSIS = 0.03  # an analysis faster than this (seconds) runs on the interface thread
#: A script up to this many characters (about 150 lines) gets its first analysis before the
#: first screen (a few tens of ms); a longer one in the background, the screen saying so.
INLINE_FIRST_ANALYSIS = 16_000
DISK_CHECK = 2.0  # seconds between checks for changes on disk


class AnalysisReady(Message):
    """The analysis of version ``version`` of the text."""

    def __init__(self, analysis: Analysis, version: int) -> None:
        super().__init__()
        self.analysis, self.version = analysis, version


class BackgroundAnalysis(Message):
    """The background analysis of version ``version`` ended (the service decides what to show)."""

    def __init__(self, analysis: Analysis, version: int, analyser: Analyser) -> None:
        super().__init__()
        self.analysis, self.version, self.analyser = analysis, version, analyser


class AnalysisFailed(Message):
    """The background analysis raised: ``text`` says what, in one line."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.text = text


class DiskChanged(Message):
    """The script on disk is no longer what the editor read or saved (``exists``: not deleted)."""

    def __init__(self, exists: bool) -> None:
        super().__init__()
        self.exists = exists


class RecoveryFound(Message):
    """Unsaved work from an earlier session, different from the file's text."""

    def __init__(self, found: Recovered) -> None:
        super().__init__()
        self.found = found


class JobUpdated(Message):
    """A job was queued, made progress, or finished (its ``state`` says which)."""

    def __init__(self, job: Job) -> None:
        super().__init__()
        self.job = job


class AnalysisService:
    """Live diagnostics: the newest version of the text, analysed once typing pauses.

    A quick analysis runs on the interface thread. A slow one (a long script's first analysis
    takes seconds) runs on a background thread, one at a time: the screen is drawn and editing
    goes on meanwhile (:attr:`analysing` says so), and when it ends the newest text is analysed
    if it changed in the meantime, reusing every chunk already done (:class:`Analyser` keeps
    them even when a run is stopped). The thread is a daemon, stopped between chunks when the
    editor closes, so quitting never waits for it.
    """

    def __init__(self, app: App, doc: Document, path: Path) -> None:
        self.app, self.doc = app, doc
        self.analyser = Analyser(path)
        self.latest: Analysis | None = None
        self.version = -1  # the version :attr:`latest` is the analysis of
        self.seconds = 1.0  # how long the last analysis took
        self._thread: threading.Thread | None = None  # the background analysis, while it runs
        self._closing = False

    @property
    def analysing(self) -> bool:
        """A background analysis is running."""
        return self._thread is not None

    @property
    def progress(self) -> float:
        """How far the analysis in progress is (0 to 1), in utterances."""
        done, total = self.analyser.progress
        return done / total if total else 0.0

    def retarget(self, path: Path) -> None:
        """The script is now ``path`` ("save as"): its diagnostics name the new file."""
        self.analyser = Analyser(path)
        self.version = -1
        self.schedule()

    @property
    def inline_first(self) -> bool:
        """Whether the first analysis is quick enough to run before the first screen."""
        return len(self.doc.text) <= INLINE_FIRST_ANALYSIS

    def start(self) -> None:
        """The first analysis, at once: on this thread when the script is short, else in the
        background (the first screen does not wait for it)."""
        if self.inline_first:
            self._publish(self._run(self.doc.text), self.doc.version)
        else:
            self._background()

    def schedule(self) -> None:
        """After a change: analyse once typing pauses (a newer change cancels this one)."""
        self.app.run_worker(self._debounced, name="analysis", group="analysis", exclusive=True)

    async def _debounced(self) -> None:
        await asyncio.sleep(ANALYSIS_DELAY)
        if self.doc.version == self.version or self.analysing:
            return  # up to date, or the running analysis starts the next one when it ends
        if self.seconds < QUICK_ANALYSIS:  # cheaper than handing it to a thread
            self._publish(self._run(self.doc.text), self.doc.version)
        else:
            self._background()

    def _background(self) -> None:
        args = (self.analyser, self.doc.text, self.doc.version)
        self._thread = threading.Thread(target=self._work, args=args, name="sgt-analysis", daemon=True)
        self._thread.start()

    def _work(self, analyser: Analyser, text: str, version: int) -> None:
        """(The background thread.) Analyse and hand the result to the interface thread."""
        try:
            result = self._run(text, stop=lambda: self._closing, analyser=analyser)
        except Stopped:
            return
        except Exception as exc:  # a bug: one line on the message line, never a traceback on the terminal
            self.app.post_message(AnalysisFailed(f"the live analysis failed: {type(exc).__name__}: {exc}"))
            return
        self.app.post_message(BackgroundAnalysis(result, version, analyser))

    def finished(self, event: "BackgroundAnalysis | AnalysisFailed") -> None:
        """(The interface thread.) The background analysis ended: show it if the text is still
        the one analysed, else analyse the newest text."""
        self._thread = None
        if isinstance(event, BackgroundAnalysis) and event.analyser is self.analyser:  # not from before "save as"
            self._publish(event.analysis, event.version)
        if self.doc.version != self.version and not self._closing:
            self.schedule()

    def now(self) -> Analysis | None:
        """The analysis of the current text, made here and now when it is stale (an action needs
        it); None while the first analysis is still running in the background."""
        if self.latest is None and self.analysing:
            return None
        if self.version != self.doc.version or self.latest is None:
            self.app.workers.cancel_group(self.app, "analysis")
            self._publish(self._run(self.doc.text), self.doc.version)
        return self.latest

    def close(self) -> None:
        """The editor is closing: a background analysis stops at its next chunk."""
        self._closing = True

    def _run(self, text: str, stop=None, analyser: Analyser | None = None) -> Analysis:
        t = time.perf_counter()
        result = (analyser or self.analyser).run(text, stop=stop)
        self.seconds = time.perf_counter() - t
        return result

    def _publish(self, analysis: Analysis, version: int) -> None:
        if version != self.doc.version:
            return  # a newer change is on its way (and scheduled its own analysis)
        self.latest, self.version = analysis, version
        self.app.post_message(AnalysisReady(analysis, version))


class DiskWatcher:
    """Notices when someone else changes (or deletes) the script on disk."""

    def __init__(self, app: App, script: ScriptFile) -> None:
        self.app, self.script = app, script

    def start(self) -> None:
        self.app.set_interval(DISK_CHECK, self.check_soon)

    def check_soon(self) -> None:
        self.app.run_worker(self.check, name="disk", group="disk", exclusive=True, thread=True)

    def check(self) -> bool:
        """Compare the file with what was read or saved (any thread); True when it changed."""
        if not self.script.changed_on_disk():
            return False
        self.app.post_message(DiskChanged(self.script.path.exists()))
        return True


class RecoveryService:
    """Keeps unsaved work in the recovery file; offers what a crash left behind."""

    def __init__(self, app: App, doc: Document, path: Path, directory: Path | None = None) -> None:
        self.app, self.doc = app, doc
        self.file = RecoveryFile(path, directory)
        self.told = False  # the user was told that the recovery file cannot be written

    def start(self) -> None:
        self.app.set_interval(INTERVAL, self.write)
        self.app.call_after_refresh(self.look)

    def write(self) -> None:
        """Write the text when it changed since the last write and is unsaved (remove it when
        saved). A write that fails is said once (a notification, and the status line while it
        lasts) and tried again every :data:`INTERVAL`; one that works again is said too."""
        self.file.update(self.doc.text, self.doc.version, self.doc.modified)
        if self.file.problem is not None and not self.told:
            self.told = True
            self.app.say(f"crash recovery is off: {self.file.problem}; save your work (ctrl+s) or set "
                         f"SGT_RECOVERY_DIR to a writable folder", "warning")
            self.app.update_status()
        elif self.file.problem is None and self.told:
            self.told = False
            self.app.say(f"crash recovery works again ({self.file.path})")
            self.app.update_status()

    def look(self) -> None:
        found = self.file.load()
        if found is None:
            return
        if found.text == self.doc.text:
            self.file.discard()
            return
        self.app.post_message(RecoveryFound(found))

    def discard(self) -> None:
        self.file.discard()

    def moved(self, path: Path) -> None:
        """The script is now saved under ``path`` ("save as"): the recovery file follows it."""
        self.file.discard()
        self.file = RecoveryFile(path, self.file.path.parent)


class JobService:
    """Generate and render jobs, one at a time, in the worker process."""

    def __init__(self, app: App) -> None:
        self.runner = JobRunner(lambda job: app.post_message(JobUpdated(job)),
                                log_path=editor_cache_dir() / "worker.log")

    @property
    def busy(self) -> bool:
        return self.runner.busy

    def submit(self, plan: JobPlan) -> Job:
        return self.runner.submit_plan(plan)

    def cancel_newest(self) -> Job | None:
        """Cancel the job asked for last (the last queued, else the running one); returns it."""
        return self.runner.cancel()

    def shutdown(self) -> None:
        self.runner.shutdown()

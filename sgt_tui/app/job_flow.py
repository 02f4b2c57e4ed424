"""Jobs as the user sees them: starting one for the cursor's utterance or the script, the job
bar, cancelling (the job asked for last, and the message says which), and showing the result:
the generated motion in the preview, a GIF's name, or a failure as one message that F2 also
lists (with the diagnostics the worker found with real speech timing).
"""

from __future__ import annotations

from pathlib import Path

from core import rules
from core.counting import plural
from core.motion import MotionFileError, load_motion
from core.skeleton import FPS
from model.weights import DEFAULT_WEIGHTS
from sgt_tui.app.panels import JobBar
from sgt_tui.editor.files import display_name
from sgt_tui.editor.jobs import CANCELLED, DONE, FAILED, Job, JobRefused, plan_job
from sgt_tui.editor.recovery import editor_cache_dir


def weights_exist(path: str | None = None) -> bool:
    return Path(path).exists() if path else DEFAULT_WEIGHTS.exists()


class JobFlow:
    def __init__(self, app) -> None:
        self.app = app

    def start(self, op: str, whole: bool) -> None:
        """Queue a generate (``op`` "generate") or render job for the cursor's utterance or the script."""
        app = self.app
        analysis = app.ready_analysis()
        if analysis is None:
            return
        try:
            plan = plan_job(op, analysis, app.area.cursor_location[0], path=app.script.path,
                            source=app.doc.text, engine=app.engine, weights=app.weights, whole=whole,
                            gif_size=app.gif_size, cache=editor_cache_dir() / "motion")
        except JobRefused as exc:
            app.say(str(exc), "warning")
            return
        app.jobs.submit(plan)

    def cancel(self) -> None:
        """Cancel the job asked for last: the last queued one, else the running one; say which."""
        app = self.app
        running = app.jobs.runner.current
        job = app.jobs.cancel_newest()
        if job is None:
            app.say("no job to cancel")
        elif job is running:
            app.say(f"cancelling {job.label} (running)")
        else:
            app.say(f"cancelled {job.label} (queued)" + (f"; {running.label} keeps running" if running else ""))

    def updated(self, job: Job) -> None:
        app = self.app
        self._bar()
        if job.state == DONE:
            app.job_problems = []
            self._done(job)
        elif job.state == FAILED:
            app.job_problems = list(job.diagnostics) or [
                rules.GENERATION.at(str(app.script.path), 0, 0, detail=f"{job.label} failed: {job.message}")]
            app.job_text = job.request.source
            app.say(f"{job.label} failed: {job.message} (F2 lists it)", "error")
        elif job.state == CANCELLED and not app.last_message.startswith(f"cancelled {job.label}"):
            app.say(f"{job.label}: cancelled")

    def _bar(self) -> None:
        """The job bar shows the running job (or the next one), and how many wait."""
        runner = self.app.jobs.runner
        shown = runner.current or next(iter(runner.queue), None)
        bar = self.app._w(JobBar)
        if shown is None:
            bar.display = False
            return
        waiting = f" (+{len(runner.queue)} queued)" if runner.queue else ""
        bar.show_job(shown.label + waiting, shown.fraction, shown.phase if shown.state == "running" else "queued")

    def _done(self, job: Job) -> None:
        app = self.app
        result = job.result
        try:
            clips = load_motion(result.motion) if result.motion else []
        except (MotionFileError, OSError) as exc:
            app.say(f"{job.label}: cannot read the motion: {exc}", "error")
            return
        for clip, index in zip(clips, result.utterances):
            if 0 <= index < len(job.keys):
                app.takes.add(job.keys[index], job.request.engine, clip)
        if job.op == "render":
            app.say(f"wrote {display_name(Path(result.gif))} ({plural(result.gif_frames, 'frame')})")
        else:
            app.say(f"{job.label}: done, {result.frames / FPS:.1f} s of motion")
        if app.current is not None and app.takes.has(app.current.key):
            # a new generation plays from the start; after a render the preview stays as it was
            # (paused stays paused, at its frame)
            playing = app.player.playing
            app.show_utterance(restart=job.op == "generate")
            app.preview.play(True if job.op == "generate" else playing)

"""The ``sgt.preview`` command: generate and render the utterance at the cursor to a GIF.

The work runs in the editor's worker process (:mod:`sgt_tui.editor.jobs`, which ``sgt edit``
uses too), so the server never imports the model or the renderer and stays responsive; the
GIF goes into the sgt cache (``lsp/previews``), its path back to the client. The speech the
preview synthesizes is then in the speech cache: hover and inlay hints use its real timing
(:mod:`sgt_tui.lsp.timing`).
"""

from __future__ import annotations

import dataclasses
import threading

from core.paths import cache_dir
from model.engines import DEFAULT_ENGINE
from sgt_tui.editor.jobs import DONE, JobRefused, JobRunner, plan_job
from sgt_tui.editor.recovery import editor_cache_dir

#: Seconds a preview may take before the client is told it failed.
TIMEOUT = 600


class PreviewFailed(Exception):
    """The utterance could not be previewed; the message says why."""


class Previews:
    def __init__(self, timing) -> None:
        self.timing = timing
        self._runner: JobRunner | None = None
        self._done = threading.Condition()

    def _on_event(self, job) -> None:
        with self._done:
            self._done.notify_all()

    def render(self, doc, row: int, engine: str | None = None, size: int = 320) -> dict:
        """Render the utterance on 0-based ``row``; returns ``{"gif", "utterance", "frames"}``."""
        analysis = doc.analysis()
        engine = engine or DEFAULT_ENGINE
        try:
            plan = plan_job("render", analysis, row, path=doc.path, source=doc.text, engine=engine,
                            gif_size=(size, size), cache=editor_cache_dir() / "motion")
        except JobRefused as exc:
            raise PreviewFailed(str(exc)) from None
        info = analysis.utterance_at(row + 1)
        gif = cache_dir("lsp") / "previews" / f"{doc.path.stem}.u{info.index + 1}.gif"
        gif.parent.mkdir(parents=True, exist_ok=True)
        if self._runner is None:
            self._runner = JobRunner(self._on_event, log_path=cache_dir("lsp") / "worker.log")
        job = self._runner.submit(dataclasses.replace(plan.request, gif=str(gif)), plan.label, plan.keys)
        with self._done:
            if not self._done.wait_for(lambda: job.finished_state, timeout=TIMEOUT):
                self._runner.cancel(job)
                raise PreviewFailed(f"the preview took more than {TIMEOUT} s")
        if job.state != DONE:
            problems = "; ".join(f"{d.line}:{d.col}: {d.message}" for d in job.diagnostics[:3])
            raise PreviewFailed(job.message + (f": {problems}" if problems else ""))
        if job.result.timing not in (None, "estimate"):
            self.timing.learn(doc, info)
        return {"gif": str(gif), "utterance": info.index + 1, "frames": job.result.gif_frames, "engine": engine}

    def shutdown(self) -> None:
        if self._runner is not None:
            self._runner.shutdown()

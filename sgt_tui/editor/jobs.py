"""Long work (generation, GIF rendering) in a worker subprocess, with progress and cancel.

:class:`JobRunner` keeps one :mod:`sgt_tui.editor.worker` process and feeds it one job at a
time from a queue. A job carries a typed :class:`~sgt_tui.editor.protocol.JobRequest` and, when
done, a :class:`~sgt_tui.editor.protocol.JobResult`. Events from the worker (progress, done,
error) reach ``on_event`` from a reader thread; the editor turns them into interface messages.
Cancelling the running job kills the worker's whole process group at once (so a busy model stops
using the CPU); the next job starts a fresh worker. Models stay loaded between jobs that are not
cancelled. :func:`newest` says which job ``ctrl+t`` means: the one the user asked for last.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import os
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from core.counting import number
from core.diagnostics import Diagnostic
from sgt_tui.editor.protocol import PHASES, Done, Failed, JobRequest, JobResult, Progress, decode_event, encode_request

QUEUED, RUNNING, DONE, FAILED, CANCELLED = "queued", "running", "done", "failed", "cancelled"
MAX_LOG = 1 << 20  # the worker's log starts afresh past this size (bytes)


@dataclass
class Job:
    id: str
    label: str
    request: JobRequest
    keys: tuple[str, ...] = ()  # the editor's key of each utterance of the script (index -> key)
    state: str = QUEUED
    phase: str = ""
    done: int = 0
    total: int = 0
    what: str = ""
    result: JobResult | None = None
    message: str = ""
    diagnostics: tuple[Diagnostic, ...] = ()
    started: float = 0.0
    finished: float = 0.0

    @property
    def op(self) -> str:
        return self.request.op

    @property
    def fraction(self) -> float:
        """Progress 0..1 over the phases (speech, motion, render)."""
        phases = PHASES if self.op == "render" else PHASES[:2]
        if self.state == DONE:
            return 1.0
        if self.phase not in phases:
            return 0.0
        i = phases.index(self.phase)
        part = self.done / self.total if self.total else 0.0
        return (i + part) / len(phases)

    @property
    def finished_state(self) -> bool:
        return self.state in (DONE, FAILED, CANCELLED)


class JobRefused(Exception):
    """The job cannot start (no utterances, errors in the script); the message says why."""


@dataclass(frozen=True)
class JobPlan:
    request: JobRequest
    label: str  # "generate utterance 2 (rules)", "gif script (neural)"
    keys: tuple[str, ...]  # the key of each utterance (the result's indices map to them)


def plan_job(op: str, analysis, row: int, *, path: Path, source: str, engine: str, weights: str | None = None,
             whole: bool = False, gif_size: tuple[int, int] = (320, 320), cache: Path) -> JobPlan:
    """The request for generating (``op`` "generate") or rendering ("render") the utterance on
    0-based ``row``, or the whole script; raises :class:`JobRefused`.

    Motion goes to ``cache`` (one file per script and utterance); a GIF goes next to the script:
    ``lobby.gif`` for the script, ``lobby.u2.gif`` for utterance 2, counting from 1 as the
    status line does."""
    if not analysis.utterances:
        raise JobRefused("nothing to generate: the script has no utterances")
    info = analysis.utterance_at(row + 1)
    bad = [u for u in analysis.utterances if u.errors] if whole else ([info] if info.errors else [])
    if bad:
        raise JobRefused(f"utterance {number(bad[0].index)} has errors: fix them first (F2 lists problems)")
    what = "script" if whole else f"utterance {number(info.index)}"
    take = _take_name(path, "all" if whole else info.key)
    request = JobRequest(op, str(path), source, engine=engine, weights=weights,
                         utterances=None if whole else (info.index,), out=str(cache / f"{take}-{engine}.npz"))
    if op == "render":
        gif = path.with_name(f"{path.stem}.gif" if whole else f"{path.stem}.u{number(info.index)}.gif")
        request = dataclasses.replace(request, gif=str(gif), size=tuple(gif_size))
    label = f"{'gif' if op == 'render' else 'generate'} {what} ({engine})"
    return JobPlan(request, label, tuple(u.key for u in analysis.utterances))


def _take_name(script: Path, what: str) -> str:
    """A cache file name for generated motion: one per script and utterance text (or 'all')."""
    return hashlib.sha1(f"{script.resolve()}|{what}".encode("utf-8")).hexdigest()[:20]


class JobRunner:
    """Runs jobs one at a time in a persistent worker process."""

    def __init__(self, on_event: Callable[[Job], None], *, env: dict | None = None, log_path: Path | None = None,
                 python: str | None = None) -> None:
        self.on_event = on_event
        self.env = env
        self.log_path = log_path
        self.python = python or sys.executable
        self.queue: deque[Job] = deque()
        self.current: Job | None = None
        self._proc: subprocess.Popen | None = None
        self._lock = threading.RLock()
        self._ids = itertools.count(1)
        self._cancelling: Job | None = None
        self.closed = False

    # -- public ---------------------------------------------------------------------------
    def submit_plan(self, plan: JobPlan) -> Job:
        return self.submit(plan.request, plan.label, plan.keys)

    def submit(self, request: JobRequest, label: str, keys: tuple[str, ...] = ()) -> Job:
        job = Job(str(next(self._ids)), label, request, tuple(keys))
        with self._lock:
            self.queue.append(job)
        self.on_event(job)
        self._next()
        return job

    def cancel(self, job: Job | None = None) -> Job | None:
        """Cancel ``job`` (default: the job asked for last that has not finished: the last queued, else the running one). Returns it, or None when nothing was left to cancel."""
        proc = None
        with self._lock:
            if job is None:
                job = self.queue[-1] if self.queue else self.current
            if job is None or job.finished_state:
                return None
            if job in self.queue:
                self.queue.remove(job)
                self._finish(job, CANCELLED, "cancelled")
            elif job is self.current:
                self._cancelling = job
                proc = self._proc
        if proc is not None:
            _kill_group(proc)
        else:
            self.on_event(job)
        return job

    @property
    def busy(self) -> bool:
        return self.current is not None or bool(self.queue)

    @property
    def worker_pid(self) -> int | None:
        return self._proc.pid if self._proc is not None and self._proc.poll() is None else None

    def shutdown(self) -> None:
        """Stop the worker (a running job is cancelled)."""
        self.closed = True
        with self._lock:
            dropped = list(self.queue)
            for job in dropped:
                self._finish(job, CANCELLED, "cancelled")
            self.queue.clear()
            proc = self._proc
            if self.current is not None:
                self._cancelling = self.current
        for job in dropped:
            self.on_event(job)
        if proc is not None:
            try:
                proc.stdin.close()
            except OSError:
                pass
            if self.current is not None:
                _kill_group(proc)
            try:
                proc.wait(timeout=2)
            except subprocess.TimeoutExpired:
                _kill_group(proc)

    # -- internals ------------------------------------------------------------------------
    @staticmethod
    def _finish(job: Job, state: str, message: str = "") -> None:
        """Mark a job finished; the caller reports it with ``on_event`` outside the lock."""
        job.state = state
        job.finished = time.monotonic()
        if message:
            job.message = message

    def _ensure_worker(self) -> subprocess.Popen:
        if self._proc is not None and self._proc.poll() is None:
            return self._proc
        env = dict(os.environ if self.env is None else self.env)
        root = str(Path(__file__).resolve().parents[2])
        env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        stderr = subprocess.DEVNULL
        if self.log_path is not None:
            self.log_path.parent.mkdir(parents=True, exist_ok=True)
            big = self.log_path.exists() and self.log_path.stat().st_size > MAX_LOG
            stderr = open(self.log_path, "wb" if big else "ab")
        proc = subprocess.Popen(
            [self.python, "-m", "sgt_tui.editor.worker"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=stderr, env=env, start_new_session=True, text=True, encoding="utf-8", bufsize=1,
        )
        if stderr is not subprocess.DEVNULL:
            stderr.close()
        self._proc = proc
        threading.Thread(target=self._read, args=(proc,), daemon=True, name="sgt-worker-reader").start()
        return proc

    def _next(self) -> None:
        with self._lock:
            if self.current is not None or not self.queue or self.closed:
                return
            job = self.queue.popleft()
            self.current = job
            job.state = RUNNING
            job.started = time.monotonic()
            try:
                proc = self._ensure_worker()
                proc.stdin.write(encode_request(job.id, job.request) + "\n")
                proc.stdin.flush()
            except OSError as exc:
                self.current = None
                self._finish(job, FAILED, f"cannot start the worker: {exc}")
        self.on_event(job)

    def _read(self, proc: subprocess.Popen) -> None:
        for line in proc.stdout:
            event = decode_event(line)
            if event is None:
                continue
            with self._lock:
                job = self.current
                if job is None or event.id != job.id or job is self._cancelling:
                    continue
                if isinstance(event, Progress):
                    job.phase, job.done, job.total, job.what = event.phase, event.done, event.total, event.what
                else:
                    self.current = None
                    if isinstance(event, Done):
                        job.result = event.result
                        self._finish(job, DONE)
                    elif isinstance(event, Failed):
                        job.diagnostics = event.diagnostics
                        self._finish(job, FAILED, event.message)
            self.on_event(job)
            if job.finished_state:
                self._next()
        # the worker ended: cancelled, shut down, or crashed
        proc.wait()
        with self._lock:
            job, self.current = self.current, None
            cancelled = self._cancelling
            self._cancelling = None
            if self._proc is proc:
                self._proc = None
            if job is not None:
                if job is cancelled:
                    self._finish(job, CANCELLED, "cancelled")
                else:
                    self._finish(job, FAILED, f"the worker stopped unexpectedly (exit status {proc.returncode})"
                                 + (f"; see {self.log_path}" if self.log_path else ""))
        if job is not None:
            self.on_event(job)
        if not self.closed:
            self._next()


def _kill_group(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        try:
            proc.kill()
        except OSError:
            pass

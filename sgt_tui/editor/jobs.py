"""Long work (generation, GIF rendering) in a worker subprocess, with progress and cancel.

:class:`JobRunner` keeps one :mod:`sgt_tui.editor.worker` process and feeds it one job at a
time from a queue. Events from the worker (progress, done, error) reach ``on_event`` from a
reader thread; the editor turns them into interface messages. Cancelling the running job kills
the worker's whole process group at once (so a busy model stops using the CPU); the next job
starts a fresh worker. Models stay loaded between jobs that are not cancelled.
"""

from __future__ import annotations

import itertools
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

QUEUED, RUNNING, DONE, FAILED, CANCELLED = "queued", "running", "done", "failed", "cancelled"
MAX_LOG = 1 << 20  # the worker's log starts afresh past this size (bytes)


@dataclass
class Job:
    id: str
    op: str  # "generate" or "render"
    label: str
    request: dict
    state: str = QUEUED
    phase: str = ""
    done: int = 0
    total: int = 0
    what: str = ""
    result: dict | None = None
    message: str = ""
    diagnostics: list = field(default_factory=list)
    started: float = 0.0
    finished: float = 0.0

    @property
    def fraction(self) -> float:
        """Progress 0..1 over the phases (speech, motion, render)."""
        phases = ["speech", "motion"] + (["render"] if self.op == "render" else [])
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
    def submit(self, op: str, label: str, **request) -> Job:
        job = Job(str(next(self._ids)), op, label, dict(request, op=op))
        with self._lock:
            self.queue.append(job)
        self.on_event(job)
        self._next()
        return job

    def cancel(self, job: Job | None = None) -> Job | None:
        """Cancel ``job`` (default: the running one, else the last queued). Returns it."""
        proc = None
        with self._lock:
            if job is None:
                job = self.current or (self.queue[-1] if self.queue else None)
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
                proc.stdin.write(json.dumps(dict(job.request, id=job.id), ensure_ascii=False) + "\n")
                proc.stdin.flush()
            except OSError as exc:
                self.current = None
                self._finish(job, FAILED, f"cannot start the worker: {exc}")
        self.on_event(job)

    def _read(self, proc: subprocess.Popen) -> None:
        for line in proc.stdout:
            try:
                event = json.loads(line)
            except ValueError:
                continue
            with self._lock:
                job = self.current
                if job is None or event.get("id") != job.id or job is self._cancelling:
                    continue
                kind = event.get("event")
                if kind == "progress":
                    job.phase = event.get("phase", "")
                    job.done, job.total, job.what = event.get("done", 0), event.get("total", 0), event.get("what", "")
                else:
                    self.current = None
                    if kind == "done":
                        job.result = event.get("result") or {}
                        self._finish(job, DONE)
                    else:
                        job.diagnostics = event.get("diagnostics") or []
                        self._finish(job, FAILED, event.get("message") or "the job failed")
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

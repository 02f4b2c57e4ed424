"""Recordings aligned in a child process, so that no request waits for the aligner.

An ``@audio`` recording without ``timings=`` is checked by aligning its transcript
(:mod:`dsl.speech.align`): about a second of work per second of audio, in C calls that hold
Python's lock for over a second at a time, so a thread would still stall the server. The server
therefore analyses a script with such a directive left out (the line blanked, so every other
place stays) until the recording's check is in the speech cache: a child process
(``python -m sgt_tui.lsp.aligning``) runs the very check the analysis runs
(:func:`dsl.speech.recording.check_recording`), which caches its verdict, one recording at a
time; the analysis with the directive then finds it there, and the diagnostics are published.

A recording no open script needs any more (its words or its file changed, the script was
closed) is not aligned: the child working on it is stopped. A child that fails (the aligner
broke, or it ran past :data:`TIMEOUT`) gives its reason, which the server reports on the
directive instead of aligning in its own process. The child exits when the server's end of its
standard input closes, so a server that dies leaves no aligner behind.
"""

from __future__ import annotations

import json
import logging
import os
import stat
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from dsl.parser import analyse
from dsl.speech import SpeechError
from dsl.speech.recording import check_recording

#: Seconds one recording may take to align before its child is stopped.
TIMEOUT = 1800
#: Seconds between looks at whether the recording being aligned is still needed.
POLL = 0.2
#: Seconds a recording must stay wanted before its child starts (while the utterance's words
#: are being typed, each keystroke wants another alignment).
SETTLE = 0.5
#: The verdicts the analysis reproduces at once: a mismatch is cached with the alignment, an
#: unreadable recording fails before aligning.
_QUICK_KINDS = ("mismatch", "audio")

log = logging.getLogger("sgt.lsp")


@dataclass(frozen=True)
class Recording:
    """An ``@audio`` directive whose recording is checked by the aligner: where its file name is
    (1-based line and column, length), and what the alignment depends on (``key``)."""

    line: int
    col: int
    length: int
    audio: str
    text: str
    spans: tuple[tuple[int, int], ...]
    key: tuple


def recordings(text: str, path: Path) -> list[Recording]:
    """The recordings of ``text`` (a script at ``path``) that the analysis aligns: those without
    ``timings=`` whose file is a regular file."""
    if "@audio" not in text:
        return []
    script = analyse(text, str(path), gesture_names=None, base_dir=path.parent)
    out = []
    for u in script.utterances:
        a = u.audio
        if a is None or a.timings is not None:
            continue
        try:
            st = os.stat(a.path)
        except (OSError, ValueError):
            continue  # the analysis says it is missing, without aligning
        if not stat.S_ISREG(st.st_mode):
            continue  # (the analysis refuses it unread)
        spans = tuple(u.word_spans)
        words = tuple(u.text[s:e] for s, e in spans)
        out.append(Recording(a.where.line, a.where.col, a.where.length, str(a.path), u.text, spans,
                             (str(a.path), st.st_mtime_ns, st.st_size, words)))
    return out


class Aligner:
    """The recordings open scripts wait for, aligned one at a time in a child process.

    ``notify(uris)`` is called (on the aligner's thread) when a recording those scripts wait for
    is done, aligned or failed."""

    def __init__(self, notify) -> None:
        self._notify = notify
        self._cond = threading.Condition()
        self._wanted: dict[str, dict[tuple, Recording]] = {}  # uri -> recordings it waits for
        self._done: dict[tuple, str | None] = {}  # key -> None (in the speech cache) or why it failed
        self._thread: threading.Thread | None = None
        self._closed = False

    def state(self, uri: str, recs: list[Recording], queue: bool = True) -> tuple[list[Recording], list[tuple[Recording, str]]]:
        """(the recordings of ``uri`` still aligning, those that failed with why) for its current
        text's ``recs``; with ``queue``, the ones still to align are what ``uri`` waits for now
        (stale work for it is dropped)."""
        with self._cond:
            waiting = [r for r in recs if r.key not in self._done]
            failed = [(r, self._done[r.key]) for r in recs if self._done.get(r.key)]
            if not queue:
                return waiting, failed
            self._wanted[uri] = {r.key: r for r in waiting}
            if waiting and not self._closed and self._thread is None:
                self._thread = threading.Thread(target=self._run, name="sgt-aligner", daemon=True)
                self._thread.start()
            self._cond.notify_all()
        return waiting, failed

    def forget(self, uri: str) -> None:
        """``uri`` was closed: it waits for nothing."""
        with self._cond:
            self._wanted.pop(uri, None)
            self._cond.notify_all()

    def close(self) -> None:
        """Stop aligning (the child at work is stopped)."""
        with self._cond:
            self._closed = True
            self._wanted.clear()
            self._cond.notify_all()

    def _next(self) -> Recording | None:
        """(Under the lock.) The first recording some script waits for, or None."""
        for recs in self._wanted.values():
            for key, rec in recs.items():
                if key not in self._done:
                    return rec
        return None

    def _wanted_now(self, key: tuple) -> bool:
        """(Under the lock.) Whether an open script waits for ``key``."""
        return any(key in recs for recs in self._wanted.values())

    def _needed(self, key: tuple) -> bool:
        with self._cond:
            return not self._closed and self._wanted_now(key)

    def _run(self) -> None:
        """(The aligner's thread.) Align what is wanted, one recording at a time."""
        while True:
            with self._cond:
                while not self._closed and (rec := self._next()) is None:
                    self._cond.wait()
                # a recording wanted only while the words are typed is not worth a child
                self._cond.wait_for(lambda: self._closed or not self._wanted_now(rec.key), SETTLE)
                if self._closed:
                    return
                if not self._wanted_now(rec.key):
                    continue
            outcome = self._align(rec)
            if outcome is _STALE:
                continue
            with self._cond:
                self._done[rec.key] = outcome
                uris = [uri for uri, recs in self._wanted.items() if rec.key in recs]
            try:
                self._notify(uris)
            except Exception:  # (the loop is gone: the server is ending)
                log.exception("could not report the alignment of %s", rec.audio)

    def _align(self, rec: Recording):
        """None (the verdict is in the speech cache), why it failed, or ``_STALE``."""
        job = json.dumps({"audio": rec.audio, "text": rec.text, "spans": rec.spans}) + "\n"
        try:
            child = subprocess.Popen([sys.executable, "-m", "sgt_tui.lsp.aligning"], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, start_new_session=True)
        except OSError as exc:
            return f"the aligner could not start: {exc.strerror or exc}"
        try:
            child.stdin.write(job.encode("utf-8"))
            child.stdin.flush()  # (kept open: the child exits when it closes)
            started = time.monotonic()
            while True:
                try:
                    child.wait(POLL)
                    break
                except subprocess.TimeoutExpired:
                    if not self._needed(rec.key):
                        return _STALE
                    if time.monotonic() - started > TIMEOUT:
                        return f"the alignment took more than {TIMEOUT} s"
            answer = child.stdout.read(64 * 1024).decode("utf-8", "replace")
        except OSError as exc:
            return f"the aligner stopped: {exc.strerror or exc}"
        finally:
            if child.poll() is None:
                child.kill()
                child.wait()
            for pipe in (child.stdin, child.stdout):
                try:
                    pipe.close()
                except OSError:
                    pass
        try:
            reply = json.loads(answer)
        except ValueError:
            return f"the aligner stopped (exit status {child.returncode})"
        return reply.get("failed") if isinstance(reply, dict) else f"the aligner stopped (exit status {child.returncode})"


_STALE = object()


def _child() -> int:
    """(The child process.) Read one job from standard input, check the recording (which
    caches the verdict), answer ``{"failed": None or why}`` on standard output; exit as soon as
    the server closes standard input."""
    job = json.loads(sys.stdin.buffer.readline())

    def watch() -> None:
        sys.stdin.buffer.read()  # returns when the server closes its end (or dies)
        os._exit(3)

    threading.Thread(target=watch, daemon=True).start()
    failed = None
    try:
        check_recording(Path(job["audio"]), job["text"], [tuple(s) for s in job["spans"]])
    except SpeechError as exc:
        if exc.kind not in _QUICK_KINDS:
            failed = exc.message.splitlines()[0] if exc.message else "the aligner failed"
    except Exception as exc:  # one line back to the server; the traceback to the server's log
        log.exception("aligning %s failed", job["audio"])
        failed = f"the aligner failed: {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
    sys.stdout.write(json.dumps({"failed": failed}) + "\n")
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    os._exit(_child())

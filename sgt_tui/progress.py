"""A small progress bar on stderr for long work (only drawn when stderr is a terminal)."""

from __future__ import annotations

import sys
import time


class ProgressBar:
    def __init__(self, label: str, stream=None, width: int = 28) -> None:
        self.label = label
        self.stream = stream or sys.stderr
        self.width = width
        self.enabled = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.started = time.monotonic()
        self._last = 0.0

    def __call__(self, done: int, total: int, what: str = "") -> None:
        if not self.enabled or total <= 0:
            return
        now = time.monotonic()
        if done < total and now - self._last < 0.1:
            return
        self._last = now
        filled = int(self.width * done / total)
        bar = "#" * filled + "-" * (self.width - filled)
        line = f"\r{self.label} [{bar}] {done}/{total} {now - self.started:5.1f}s {what[:30]:<30}"
        self.stream.write(line)
        if done >= total:
            self.stream.write("\r" + " " * len(line) + "\r")
        self.stream.flush()


class BuildProgress:
    """``sgt build``'s bar on stderr: utterances done (generated or cached), cached, failed and
    an ETA from the rate of generation so far; drawn only when stderr is a terminal."""

    def __init__(self, stream=None, width: int = 24) -> None:
        self.stream = stream or sys.stderr
        self.width = width
        self.enabled = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.started = time.monotonic()
        self._first: tuple[float, int] | None = None  # (time, done) when generation started
        self._last = 0.0
        self._shown = 0

    def __call__(self, count) -> None:
        now = time.monotonic()
        if self._first is None:
            self._first = (now, count.done)
        finished = count.done + count.failed >= count.total
        if not self.enabled or (not finished and now - self._last < 0.1):
            return
        self._last = now
        self.stream.write("\r" + self.line(count, now).ljust(self._shown) + ("\n" if finished else ""))
        self._shown = 0 if finished else len(self.line(count, now))
        self.stream.flush()

    def line(self, count, now: float) -> str:
        total = max(1, count.total)
        filled = int(self.width * (count.done + count.failed) / total)
        bar = "#" * filled + "-" * (self.width - filled)
        left = count.total - count.done - count.failed
        eta = "--"
        t0, d0 = self._first or (now, count.done)
        if left and count.done > d0 and now > t0:
            eta = _clock(left * (now - t0) / (count.done - d0))
        elif not left:
            eta = "0s"
        return (f"build [{bar}] {count.done}/{count.total} utterances, {count.cached} cached, "
                f"{count.failed} failed, {_clock(now - self.started)} elapsed, ETA {eta}")


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"

"""Cooperative cancellation: work that nobody waits for any more stops at its next loop point.

A job runs under a :class:`Token` (:func:`scope`, context-local: one per thread or task). Its
owner cancels the token (:meth:`Token.cancel`: ``sgt serve`` does when a request times out
or its client disconnects, sgt_tui/serve/pool.py) or gives it a deadline; the work calls
:func:`check` at its loop points (per utterance and per pose mark while compiling, per
utterance of speech, per window of the network, per chunk of the audio features, per pass of
the face, hands and performance), which raises :class:`Cancelled` once the token is
cancelled or past its deadline. Outside a scope :func:`check` is a context-variable lookup
and never raises: the commands run without one. In every scope it also raises
KeyboardInterrupt once the command has been sent ctrl+c (:func:`core.interrupts.interrupted`),
however a library swallowed it.

:class:`Cancelled` is a :class:`BaseException`, like ``KeyboardInterrupt``: the ``except
Exception`` that turns a library's failure into a user's message does not swallow it.

Standard library only.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from core.interrupts import interrupted

#: Iterations of a per-frame loop between two checks (a few milliseconds of work): such a loop
#: calls :func:`check` when ``not i % EVERY``.
EVERY = 1024


class Cancelled(BaseException):
    """The work's token was cancelled; ``reason`` says why (e.g. "the request timed out")."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class Token:
    """Cancelled once: by :meth:`cancel` (from any thread) or when ``deadline``
    (:func:`time.monotonic` seconds) has passed."""

    def __init__(self, deadline: float | None = None) -> None:
        self.deadline = deadline
        self.reason = ""
        self._event = threading.Event()

    def cancel(self, reason: str) -> None:
        """Cancel the work (the first reason given is kept)."""
        if not self._event.is_set():
            self.reason = reason
            self._event.set()

    @property
    def cancelled(self) -> bool:
        if not self._event.is_set() and self.deadline is not None and time.monotonic() >= self.deadline:
            self.cancel("its time is up")
        return self._event.is_set()


_current: ContextVar[Token | None] = ContextVar("sgt_cancel_token", default=None)


def check() -> None:
    """Raise :class:`Cancelled` when the work running here has been cancelled, and
    KeyboardInterrupt when the command has been sent ctrl+c."""
    token = _current.get()
    if token is not None and token.cancelled:
        raise Cancelled(token.reason)
    if interrupted():
        raise KeyboardInterrupt


def scope(token: Token):
    """Run the block under ``token``: :func:`check` in it (in this thread or task) answers to it."""
    return set_for_block(_current, token)


@contextmanager
def set_for_block(var: ContextVar, value) -> Iterator:
    """``var`` set to ``value`` in the block (in this thread or task), as it was after it: how a
    job's token, or its limits (:func:`core.limits.using`), are put in force."""
    reset = var.set(value)
    try:
        yield value
    finally:
        var.reset(reset)

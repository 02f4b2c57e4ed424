"""Worker threads and the bounded queue in front of them.

Generation runs in threads, off the event loop (numpy and onnxruntime release the GIL for
their heavy parts; espeak-ng calls are serialised by :mod:`dsl.speech._espeak`). At most
``workers + queue`` requests are admitted at once; one more gets :class:`Busy`, answered 503
with a Retry-After from the recent job times.

Each job runs under its own :class:`core.cancel.Token`, with the request's deadline: when the
request times out (408) or its client goes (:class:`ClientGone`), the token is cancelled and the
work stops at its next loop point (:func:`core.cancel.check`), within about a second. A job
keeps its slot until its thread has really ended, so a flood of slow requests cannot pile up
threads either.
"""

from __future__ import annotations

import asyncio
import math
import statistics
import threading
import time
from collections import deque
from collections.abc import Awaitable, Callable
from concurrent.futures import ThreadPoolExecutor

from core import cancel


class Busy(Exception):
    """The queue is full; ``retry_after`` seconds is a fair wait."""

    def __init__(self, retry_after: int) -> None:
        super().__init__(f"the service is busy; retry after {retry_after} s")
        self.retry_after = retry_after


class ClientGone(Exception):
    """The client went away before its answer was ready (its work is cancelled)."""


class Pool:
    def __init__(self, workers: int, queue: int) -> None:
        self.workers = workers
        self.capacity = workers + queue
        self.executor = ThreadPoolExecutor(workers, thread_name_prefix="sgt-serve")
        self.admitted = 0
        self.completed = 0
        self.rejected = 0
        self.cancelled = 0
        self.durations: deque[float] = deque(maxlen=64)
        self.lock = threading.Lock()

    def retry_after(self) -> int:
        """Seconds until a slot is likely free: the queue ahead, at the median job time."""
        typical = statistics.median(self.durations) if self.durations else 1.0
        return max(1, math.ceil(typical * max(1, self.admitted - self.workers + 1) / self.workers))

    async def run(self, fn, *args, timeout: float, gone: Callable[[], Awaitable] | None = None):
        """``fn(*args)`` in a worker thread under a cancel token; raises :class:`Busy` when full,
        ``TimeoutError`` after ``timeout`` seconds and :class:`ClientGone` when ``gone()`` (an
        awaitable that ends when the client disconnects) ends first, both after cancelling the work."""
        with self.lock:
            if self.admitted >= self.capacity:
                self.rejected += 1
                raise Busy(self.retry_after())
            self.admitted += 1
        started = time.monotonic()
        token = cancel.Token(deadline=started + timeout)

        def job():
            with cancel.scope(token):
                return fn(*args)

        def finished(_future) -> None:
            with self.lock:
                self.admitted -= 1
                self.completed += 1
                self.durations.append(time.monotonic() - started)

        future = self.executor.submit(job)
        future.add_done_callback(finished)
        answer = asyncio.wrap_future(future)
        watch = asyncio.ensure_future(gone()) if gone is not None else None
        try:
            done, _ = await asyncio.wait([answer] + ([watch] if watch else []), timeout=timeout,
                                         return_when=asyncio.FIRST_COMPLETED)
        except asyncio.CancelledError:  # the server is shutting down
            token.cancel("the service is stopping")
            answer.cancel()
            raise
        finally:
            if watch is not None:
                watch.cancel()
        if answer in done:
            try:
                return answer.result()
            except cancel.Cancelled:  # its deadline passed in the worker, a moment before here
                self._cancelled()
                raise TimeoutError from None
        client_gone = watch is not None and watch in done
        token.cancel("its client went away" if client_gone else "the request timed out")
        answer.cancel()  # the thread ends at its next check, and frees the slot then
        self._cancelled()
        if client_gone:
            raise ClientGone
        raise TimeoutError

    def _cancelled(self) -> None:
        with self.lock:
            self.cancelled += 1

    def stats(self) -> dict:
        with self.lock:
            return {"workers": self.workers, "capacity": self.capacity, "admitted": self.admitted,
                    "completed": self.completed, "rejected": self.rejected, "cancelled": self.cancelled}

    def shutdown(self) -> None:
        self.executor.shutdown(wait=False, cancel_futures=True)

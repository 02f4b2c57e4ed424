"""Worker threads and the bounded queue in front of them.

Generation runs in threads, off the event loop (numpy and onnxruntime release the GIL for
their heavy parts; espeak-ng calls are serialised by :mod:`dsl.speech._espeak`). At most
``workers + queue`` requests are admitted at once; one more gets :class:`Busy`, answered 503
with a Retry-After from the recent job times. A request that times out (408) keeps its slot
until its thread ends, so a flood of slow requests cannot pile up threads either.
"""

from __future__ import annotations

import asyncio
import math
import statistics
import threading
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor


class Busy(Exception):
    """The queue is full; ``retry_after`` seconds is a fair wait."""

    def __init__(self, retry_after: int) -> None:
        super().__init__(f"the service is busy; retry after {retry_after} s")
        self.retry_after = retry_after


class Pool:
    def __init__(self, workers: int, queue: int) -> None:
        self.workers = workers
        self.capacity = workers + queue
        self.executor = ThreadPoolExecutor(workers, thread_name_prefix="sgt-serve")
        self.admitted = 0
        self.completed = 0
        self.rejected = 0
        self.durations: deque[float] = deque(maxlen=64)
        self.lock = threading.Lock()

    def retry_after(self) -> int:
        """Seconds until a slot is likely free: the queue ahead, at the median job time."""
        typical = statistics.median(self.durations) if self.durations else 1.0
        return max(1, math.ceil(typical * max(1, self.admitted - self.workers + 1) / self.workers))

    async def run(self, fn, *args, timeout: float):
        """``fn(*args)`` in a worker thread; raises :class:`Busy` when full and
        ``TimeoutError`` after ``timeout`` seconds."""
        with self.lock:
            if self.admitted >= self.capacity:
                self.rejected += 1
                raise Busy(self.retry_after())
            self.admitted += 1
        started = time.monotonic()

        def finished(_future) -> None:
            with self.lock:
                self.admitted -= 1
                self.completed += 1
                self.durations.append(time.monotonic() - started)

        future = self.executor.submit(fn, *args)
        future.add_done_callback(finished)
        return await asyncio.wait_for(asyncio.wrap_future(future), timeout)

    def stats(self) -> dict:
        with self.lock:
            return {"workers": self.workers, "capacity": self.capacity, "admitted": self.admitted,
                    "completed": self.completed, "rejected": self.rejected}

    def shutdown(self) -> None:
        self.executor.shutdown(wait=False, cancel_futures=True)

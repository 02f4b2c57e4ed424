"""A render's frames drawn in worker processes, handed back in order.

Drawing a frame (the mannequin through the offscreen GL, the overlays, the face's close-up) is
most of a render's time and each frame depends only on the take, so long takes draw their
frames in ``jobs`` spawned worker processes (:func:`core.workers.spawn_context`: no inherited
GL state or threads, SIGINT blocked), each with its own GL context: a worker sets
``PYOPENGL_PLATFORM`` (:mod:`renders.gl`) before it imports OpenGL, as any process does.
This process meanwhile encodes what comes back (the GIF's LZW, the MP4's H.264), in frame
order, so the output does not depend on the number of workers.

:class:`Workers` runs a picklable ``setup(*args)`` once per worker, which returns the worker's
``draw(frame, extra)``; :meth:`Workers.map` hands out runs of :data:`CHUNK` consecutive frames
and keeps at most :data:`AHEAD` runs per worker in flight, so memory does not grow with the
take. Closed (ctrl+c, an error) the workers are stopped at once: none outlives the command.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator
from typing import Self

from core.cancel import check
from core.workers import spawn_context, stop

#: Frames a worker draws per task: enough that the hand-over costs little, few enough that
#: every worker has work until the end.
CHUNK = 8
#: Tasks per worker in flight (drawn or waiting to be collected): a bound on memory.
AHEAD = 2


class WorkerDied(Exception):
    """A worker process died (killed, out of memory); one line for users."""


_DRAW: list = []  # in a worker: its draw(frame, extra)


def _start(setup: Callable, args: tuple) -> None:
    _DRAW.append(setup(*args))


def _draw_run(first: int, stop: int, extra) -> list:
    draw = _DRAW[0]
    return [draw(f, extra) for f in range(first, stop)]


class Workers:
    """``jobs`` worker processes, each drawing with the ``setup(*args)`` it ran when it started.
    Use as a context manager, or call :meth:`close`."""

    def __init__(self, jobs: int, setup: Callable, args: tuple) -> None:
        from concurrent.futures import ProcessPoolExecutor

        self.jobs = int(jobs)
        self.started: list = []  # every worker process, recorded before the executor does
        self.pool = ProcessPoolExecutor(max_workers=self.jobs, mp_context=spawn_context(self.started),
                                        initializer=_start, initargs=(setup, args))

    def map(self, n_frames: int, extra=None) -> Iterator:
        """``draw(f, extra)`` of every frame f in 0..n_frames-1, in order."""
        from concurrent.futures.process import BrokenProcessPool

        runs = deque()
        starts = iter(range(0, n_frames, CHUNK))
        try:
            for first in starts:
                runs.append(self.pool.submit(_draw_run, first, min(n_frames, first + CHUNK), extra))
                if len(runs) >= AHEAD * self.jobs:
                    break
            while runs:
                check()
                done = runs.popleft().result()
                first = next(starts, None)
                if first is not None:
                    runs.append(self.pool.submit(_draw_run, first, min(n_frames, first + CHUNK), extra))
                yield from done
        except BrokenProcessPool:
            raise WorkerDied("a render worker process died (killed, or out of memory); "
                             "render again, or with --jobs 1") from None
        finally:
            for future in runs:
                future.cancel()

    def close(self, wait: bool = True) -> None:
        """Stop the workers: without ``wait`` at once (interrupted, or failed)."""
        stop(self.pool, self.started, wait)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, kind, exc, tb) -> None:
        self.close(wait=kind is None)

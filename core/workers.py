"""Worker processes that a command starts and stops itself: how many (:func:`default_jobs`), and
the "spawn" context whose workers never see the terminal's ctrl+c (:func:`spawn_context`).

Used by ``sgt build``'s local runner (:mod:`sgt_tui.build.runners`) and by the renders' frame
workers (:mod:`renders.frames`).
"""

from __future__ import annotations

import os
import signal
import threading
import weakref
from multiprocessing.context import SpawnContext, SpawnProcess


def default_jobs() -> int:
    """The CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def spawn_context(started: list):
    """The "spawn" context, with workers that start with SIGINT blocked; every process it
    starts is appended to ``started``.

    ctrl+c on a terminal sends SIGINT to the whole foreground process group: the build's
    workers too. A worker that got it while Python started (``site`` runs the ``.pth`` files),
    while it imported sgt or while it generated printed a KeyboardInterrupt traceback each,
    after the build's one "interrupted" line. The command stops its workers itself (SIGTERM,
    e.g. :meth:`sgt_tui.build.runners.LocalPool.close`), so they need never see SIGINT: a process inherits the signal
    mask of the thread that forks it, across ``exec``, so each worker is started from a thread
    that blocks SIGINT for that moment (a SIGINT meanwhile waits, and reaches this process
    once the mask is restored).

    That SIGINT then lands right after ``start`` returns, before the executor has recorded the
    new process: ``started`` records it first (with SIGINT still blocked), so that
    the command stops it too. (Left running, it outlived the build and printed a
    traceback when the semaphores it was unpickling had gone with the build.)"""
    import multiprocessing

    if not hasattr(signal, "pthread_sigmask"):  # not POSIX
        return multiprocessing.get_context("spawn")

    class QuietSpawn(SpawnContext):
        def Process(self, *args, **kwargs):
            proc = _QuietProcess(*args, **kwargs)
            _RECORD[proc] = started
            return proc

    return QuietSpawn()


#: Where each :class:`_QuietProcess` records itself when it starts (not on the process object:
#: that is pickled for the child).
_RECORD: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class _QuietProcess(SpawnProcess):
    """A spawned process that starts with SIGINT blocked (see :func:`spawn_context`)."""

    def start(self) -> None:
        # The mask keeps SIGINT from the child; it does not keep it from this process's other
        # threads (the executor's), whose delivery still runs the Python handler here, in the
        # middle of start(): the child then read half its start-up data and printed an EOFError
        # traceback. So the handler is held off too, and a SIGINT meanwhile raised after.
        held: list = []
        main = threading.current_thread() is threading.main_thread()
        handler = signal.signal(signal.SIGINT, lambda *a: held.append(a)) if main else None
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            super().start()
            record = _RECORD.get(self)
            if record is not None:
                record.append(self)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
            if main:
                signal.signal(signal.SIGINT, handler)
                if held and callable(handler):
                    handler(*held[0])
                elif held and handler == signal.default_int_handler:
                    raise KeyboardInterrupt


def stop(pool, started: list, wait: bool = True) -> None:
    """Shut down the executor ``pool`` whose processes :func:`spawn_context` recorded in
    ``started``; without ``wait`` its workers are terminated at once (interrupted, failed, or
    no longer needed: there is no public way to stop a worker that is still starting)."""
    if not wait:
        for proc in started:
            if proc.exitcode is None:
                proc.terminate()
    pool.shutdown(wait=True, cancel_futures=True)
    for proc in started:  # one the executor never recorded (see spawn_context)
        proc.join()

"""Ctrl+C that always stops the program, even while a library swallows it.

trimesh (imported by pyrender) wraps its optional imports in ``except BaseException``: a
SIGINT that lands while they run raises :class:`KeyboardInterrupt` inside the ``try``, which
is caught and dropped, and the command runs on to the end. Inside :func:`interrupts_deferred`
a SIGINT is only recorded; when the block ends it is delivered (``KeyboardInterrupt``).

Standard library only.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager


@contextmanager
def interrupts_deferred():
    """Hold SIGINT while the block runs, then deliver it to the handler that was there.

    Only in the main thread (where Python runs signal handlers), and only when a Python
    handler is installed (the default raises KeyboardInterrupt); an ignored SIGINT stays
    ignored."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGINT)
    if not callable(previous):
        yield
        return
    received: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if received:
            previous(signal.SIGINT, None)

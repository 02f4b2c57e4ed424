"""Ctrl+C that always stops the program, even while a library swallows it.

trimesh (imported by pyrender) wraps its optional imports in ``except BaseException``: a
SIGINT that lands while they run raises :class:`KeyboardInterrupt` inside the ``try``, which
is caught and dropped, and the command runs on to the end. Inside :func:`interrupts_deferred`
a SIGINT is only recorded; when the block ends it is delivered (``KeyboardInterrupt``).

The same holds an optional import that is tried with ``except ImportError``: a SIGINT while a
C extension initialises (onnxruntime's pybind11 module, measured) comes out of the import as
an ImportError, which such code takes for a missing package (the neural engine fell back to
PyTorch and `sgt render` ran on). Import optional packages with :func:`import_optional`.
:func:`caused_by_interrupt` tells an error that carries a KeyboardInterrupt in its chain.

Whatever swallows one unforeseen, a SIGINT that :func:`noting_interrupts` has seen stops the
work at its next loop point: :func:`core.cancel.check` raises KeyboardInterrupt once
:func:`interrupted` is true.

Standard library only.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from importlib import import_module


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


def import_optional(name: str):
    """``import name`` for a package that may be missing (the caller catches ImportError), with
    SIGINT held while it loads: a Ctrl-C then arrives as itself, never as "not installed"."""
    with interrupts_deferred():
        return import_module(name)


_SEEN: list[int] = []  # SIGINTs the handler of :func:`noting_interrupts` has seen


@contextmanager
def noting_interrupts():
    """While the block runs, SIGINT raises KeyboardInterrupt as Python's default handler does,
    and is remembered (:func:`caused_by_interrupt` then counts any error as Ctrl-C): a
    KeyboardInterrupt raised inside a C extension's import can come out as an unrelated
    ImportError with nothing in its chain (numpy's ``PyCapsule_Import could not import
    module "datetime"``, seen in CI). Main thread only, and only over Python's default handler
    (an ignored SIGINT stays ignored); the handler before is put back after."""
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or previous is not signal.default_int_handler:
        yield
        return

    def handler(signum, frame):
        _SEEN.append(signum)
        raise KeyboardInterrupt

    _SEEN.clear()
    signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        _SEEN.clear()  # dealt with: the block has ended (a process that goes on is not interrupted)


def interrupted() -> bool:
    """Whether :func:`noting_interrupts`'s handler has seen a SIGINT (the command is to stop,
    even where a library caught the KeyboardInterrupt and went on)."""
    return bool(_SEEN)


def caused_by_interrupt(exc: BaseException | None) -> bool:
    """Whether ``exc`` is Ctrl-C in disguise: a KeyboardInterrupt, or an error whose cause or
    context chain holds one (Python 3.11 turns a KeyboardInterrupt raised while a class body
    sets up its fields, ``__set_name__``, into a RuntimeError caused by it; libraries wrap what
    they catch the same way); or any error once :func:`noting_interrupts`'s handler has seen a
    SIGINT (a C extension may have dropped the KeyboardInterrupt from the chain)."""
    if _SEEN and exc is not None:
        return True
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False

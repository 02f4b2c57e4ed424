"""One build at a time into an output folder: an exclusive lock on ``OUT/.sgt-build.lock``.

Two builds writing one folder at once left outputs that the manifest did not describe (each
wrote its own files and its own manifest over the other's). :func:`locked` takes an
exclusive ``flock`` on the lock file for the whole build; a second build waits for it (its
``waiting`` callback is told once, with the holder's pid) or, without ``wait``, raises
:class:`Busy`. The kernel lets go of the lock when its holder ends, ``kill -9`` included, so a
killed build never leaves the folder locked.

The holder writes its pid (and host) into the file for the message of the build that waits,
and removes the file before it lets go; a build that was waiting on a file removed meanwhile
locks the new one instead (it checks that the file it holds is still the one at that path).
The lock file is written in place on purpose, not replaced (:func:`core.fileio.atomic_write`
would give the path a new file, which another build would lock beside this one).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from pathlib import Path

from core.fileio import OutputError, make_folder

LOCK = ".sgt-build.lock"


class Busy(Exception):
    """Another build holds the folder and the caller would not wait (one line for users)."""


def holder_of(fd: int) -> str:
    """``pid 1234`` (``pid 1234 on HOST`` from another machine), or ``''`` when not yet written."""
    import socket

    try:
        fields = os.pread(fd, 256, 0).decode("utf-8", "replace").split()
    except OSError:
        return ""
    if not fields or not fields[0].isdigit():
        return ""
    host = fields[1] if len(fields) > 1 else ""
    return f"pid {fields[0]}" + (f" on {host}" if host and host != socket.gethostname() else "")


@contextlib.contextmanager
def locked(out: Path, *, wait: bool = True, waiting: Callable[[str], None] | None = None):
    """Hold the lock of the output folder ``out`` (created if missing) while the block runs."""
    import fcntl
    import socket

    make_folder(out)
    path = Path(out) / LOCK
    told = False
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise OutputError(f"cannot lock the output folder {out} ({LOCK}): {exc.strerror or exc}") from None
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                if not wait:
                    raise Busy(_busy(out, holder_of(fd))) from None
                if not told and waiting is not None:
                    waiting(holder_of(fd))
                    told = True
                fcntl.flock(fd, fcntl.LOCK_EX)  # ctrl+c here is an interrupt, as anywhere
            if _same_file(fd, path):
                break
        except OSError as exc:
            os.close(fd)
            raise OutputError(f"cannot lock the output folder {out} ({LOCK}): {exc.strerror or exc}") from None
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)  # the holder removed it while this build waited: lock the new one
    try:
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()} {socket.gethostname()}\n".encode("utf-8", "replace"), 0)
        except OSError:
            pass  # the message of a build that waits names no pid then; the lock holds
        yield
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)
        os.close(fd)


def _same_file(fd: int, path: Path) -> bool:
    try:
        a, b = os.fstat(fd), os.stat(path)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _busy(out: Path, holder: str) -> str:
    who = f" ({holder})" if holder else ""
    return f"{out} is being built by another sgt build{who}; run again when it ends (without --no-wait it waits for it)"

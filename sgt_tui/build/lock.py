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
would give the path a new file, which another build would lock beside this one). It is opened
relative to the open folder without following a link (``O_NOFOLLOW``, as
:class:`core.fileio.Inside` does): a link or anything but a regular file of one link planted
there is refused with one line, never opened, truncated or written.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from pathlib import Path

from core.fileio import Inside, LinkRefused, OutputError

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
    folder = Inside(out, create=True)
    try:
        with _lock_file(folder, Path(out) / LOCK, wait, waiting):
            yield
    finally:
        folder.close()


@contextlib.contextmanager
def _lock_file(folder: Inside, path: Path, wait: bool, waiting):
    import fcntl
    import socket

    told = False
    while True:
        fd = _open_lock(folder, path)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                if not wait:
                    raise Busy(_busy(folder.folder, holder_of(fd))) from None
                if not told and waiting is not None:
                    waiting(holder_of(fd))
                    told = True
                fcntl.flock(fd, fcntl.LOCK_EX)  # ctrl+c here is an interrupt, as anywhere
            if _same_file(fd, folder.fd):
                break
        except OSError as exc:
            os.close(fd)
            raise OutputError(f"cannot lock the output folder {folder.folder} ({LOCK}): {exc.strerror or exc}") from None
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
            os.unlink(LOCK, dir_fd=folder.fd)
        os.close(fd)


def _open_lock(folder: Inside, path: Path) -> int:
    """The lock file, opened (created if missing) in the open folder, never through a link; a
    FIFO, a device or a file with other hard links there is refused (truncating it would
    change another file)."""
    import stat

    try:
        fd = os.open(LOCK, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC, 0o644, dir_fd=folder.fd)
    except OSError as exc:
        try:
            folder.check(LOCK)  # a link there: LinkRefused, with its one line
        except LinkRefused:
            raise
        except OSError:
            pass
        raise OutputError(f"cannot lock the output folder {folder.folder} ({LOCK}): {exc.strerror or exc}") from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
        os.close(fd)
        what = "not a regular file" if not stat.S_ISREG(st.st_mode) else "a file with other hard links"
        raise OutputError(f"cannot lock the output folder {folder.folder}: {path} is {what}; remove it")
    os.set_blocking(fd, True)
    return fd


def _same_file(fd: int, folder_fd: int) -> bool:
    """Whether the open lock file ``fd`` is still the one named :data:`LOCK` in the folder."""
    try:
        a, b = os.fstat(fd), os.stat(LOCK, dir_fd=folder_fd, follow_symlinks=False)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _busy(out: Path, holder: str) -> str:
    who = f" ({holder})" if holder else ""
    return f"{out} is being built by another sgt build{who}; run again when it ends (without --no-wait it waits for it)"

"""Helpers for tests of outputs: device nodes, FIFOs, an unprivileged child process.

Tests never write to the machine's own /dev/null, /dev/full or /dev/stdout: if the code under
test regressed, running them as root would replace those with regular files (it happened once
while proving a test could fail). They make their own nodes in the test's folder instead.
"""

from __future__ import annotations

import os
import stat
import threading
import traceback
from contextlib import contextmanager
from pathlib import Path

import pytest

IS_ROOT = os.geteuid() == 0
needs_root = pytest.mark.skipif(not IS_ROOT, reason="creating a device node (os.mknod) needs root")


def char_device(path: Path, like: str = "/dev/null") -> Path:
    """A character device with the numbers of ``like`` (/dev/null: writes vanish; /dev/full:
    writes fail, disk full), made with os.mknod at ``path``."""
    os.mknod(path, 0o666 | stat.S_IFCHR, os.stat(like).st_rdev)
    return path


def is_char_device(path: Path, like: str = "/dev/null") -> bool:
    st = os.lstat(path)
    return stat.S_ISCHR(st.st_mode) and st.st_rdev == os.stat(like).st_rdev


class FifoReader:
    """A FIFO at ``path`` whose every writer is read to the end in a thread."""

    def __init__(self, path: Path) -> None:
        os.mkfifo(path)
        self.path, self.data, self.stop = path, bytearray(), False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.stop:
            with open(self.path, "rb") as f:
                self.data += f.read()

    def close(self) -> bytes:
        """Stop reading; returns everything written."""
        self.stop = True
        while self.thread.is_alive():
            try:  # wakes a reader blocked in open(); ENXIO: none is waiting there yet
                os.close(os.open(self.path, os.O_WRONLY | os.O_NONBLOCK))
            except OSError:
                pass
            self.thread.join(0.05)
        return bytes(self.data)


class FifoWriter:
    """A FIFO at ``path`` that gives ``data`` to every reader, from a thread."""

    def __init__(self, path: Path, data: bytes) -> None:
        os.mkfifo(path)
        self.path, self.data, self.stop = path, data, False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.stop:
            try:
                with open(self.path, "wb") as f:
                    f.write(self.data)
            except BrokenPipeError:
                pass

    def close(self) -> None:
        self.stop = True
        while self.thread.is_alive():
            fd = os.open(self.path, os.O_RDONLY | os.O_NONBLOCK)  # wakes a writer blocked in open()
            self.thread.join(0.05)
            os.close(fd)


def as_unprivileged(fn) -> list[str]:
    """``fn()``'s lines, computed in a forked child of an ordinary user: nobody (65534) when the
    tests run as root, who may write anywhere. Import what ``fn`` needs before calling this:
    nobody may not be able to read the Python installation."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child
        os.close(r)
        status = 0
        try:
            if IS_ROOT:
                os.setgroups([])
                os.setgid(65534)
                os.setuid(65534)
            text = "\n".join(fn())
        except BaseException:
            text, status = traceback.format_exc(), 1
        os.write(w, text.encode())
        os._exit(status)
    os.close(w)
    with os.fdopen(r, "rb") as f:
        out = f.read().decode()
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0, out
    return out.splitlines()


@contextmanager
def shared_folder():
    """A folder that another user can reach, in the system's temporary folder: pytest's own
    folders are private, and a pytest starting in another session makes them private again."""
    import shutil
    import tempfile

    d = Path(tempfile.mkdtemp(prefix="sgt-shared-"))
    d.chmod(0o777)
    try:
        yield d
    finally:
        for sub in d.rglob("*"):  # let rmtree into folders a test locked
            if sub.is_dir() and not sub.is_symlink():
                sub.chmod(0o755)
        shutil.rmtree(d, ignore_errors=True)

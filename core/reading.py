"""Bounded reading: every input file sgt reads (scripts, timings, gesture specs, motion files,
configuration) goes through :func:`read_bytes`, with one set of rules:

- **Only regular files.** The file is opened without blocking (``O_NONBLOCK``: a FIFO with no
  writer does not hang the command) and checked with ``fstat`` on the open descriptor, so a
  FIFO, a device (``/dev/zero``, ``/dev/random``), a socket or a folder is refused by what it
  is, even through a symbolic link, and never read.
- **Bounded size.** Each kind of input has a limit (:data:`LIMITS`); a larger file is refused
  before it is read, and a file that grows while it is read is refused at the limit: memory
  is never the limit.
- **Bounded nesting.** JSON is parsed by :func:`loads_json`, which refuses nesting deeper than
  :data:`MAX_JSON_DEPTH` before the parser recurses (a deeply nested file gave a
  RecursionError traceback).

Failures raise :class:`InputFileError` (an :class:`OSError`) whose ``reason`` is one line
for users ("it is a FIFO, not a file"); callers turn it into their diagnostic or message.
:func:`open_input` applies the same checks and hands back the open file, for readers that
take what they need from it (NPZ archives, :mod:`core.npz`).

Standard library only.
"""

from __future__ import annotations

import json
import os
import re
import stat

MiB = 1 << 20

#: The largest input of each kind, bytes. A script of 10,000 lines is about 1 MiB.
LIMITS = {
    "script": 32 * MiB,
    "timings": 32 * MiB,
    "gesture spec": 1 * MiB,
    "configuration": 1 * MiB,
    "motion file": 1024 * MiB,
    "motion capture": 512 * MiB,  # a BVH take: 10 minutes at 120 fps with 75 joints is about 150 MiB
    "audio": 1024 * MiB,  # a training take's recording: an hour of 48 kHz 16-bit stereo is 660 MiB
    "checkpoint": 4096 * MiB,  # sgt train's checkpoint.pt: about 3 times the weights (Adam's two moments)
    "weights": 1024 * MiB,  # a network's weights (the shipped generator.pt is 3.9 MB)
    "matching database": 1024 * MiB,
    "corpus shard": 1024 * MiB,
    "corpus manifest": 256 * MiB,
}

#: The deepest nesting of arrays and objects a JSON input may have (motion files need 4).
MAX_JSON_DEPTH = 32

#: An escape (so an escaped quote is no quote), a quote or a bracket: what :func:`_depth` looks at.
_JSON_MARKS = re.compile(r'\\.|["\[\]{}]')


class InputFileError(OSError):
    """An input that cannot be read by the rules above; ``reason`` is why, in a few words."""

    def __init__(self, path, reason: str) -> None:
        super().__init__(f"{os.fspath(path)}: {reason}")
        self.path = path
        self.reason = reason

    def __str__(self) -> str:
        return self.args[0]


def kind_of(mode: int) -> str:
    """What a file of ``st_mode`` is, for messages: "a folder", "a FIFO", "a character device"..."""
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def not_a_file(path) -> str | None:
    """Why ``path`` is not a regular file to read ("it is a FIFO (named pipe), not a file"), or
    None when it is one or does not exist (``os.stat``: links followed; nothing is opened)."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return None if stat.S_ISREG(st.st_mode) else f"it is {kind_of(st.st_mode)}, not a file"


def read_bytes(path, what: str = "script", limit: int | None = None) -> bytes:
    """The contents of the regular file ``path``, at most ``limit`` bytes (default: the limit of
    ``what`` in :data:`LIMITS`). Raises :class:`InputFileError` for anything else (a missing
    file raises :class:`FileNotFoundError`, a folder :class:`IsADirectoryError`, as ``open``)."""
    limit = LIMITS[what] if limit is None else limit
    with open_input(path, what, limit) as f:
        chunks, total = [], 0
        while True:
            chunk = f.read(min(1 << 20, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:  # it grew while being read
                raise InputFileError(path, _too_large(total, limit, what))
        return b"".join(chunks)


def open_input(path, what: str = "script", limit: int | None = None):
    """The regular file ``path`` opened for reading (binary), by the rules of
    :func:`read_bytes`: anything but a regular file, or one larger than ``limit`` (default: the
    limit of ``what``), raises before a byte is read. For readers that seek (an NPZ archive):
    the file may still grow after the check, which they must bound themselves."""
    limit = LIMITS[what] if limit is None else limit
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise IsADirectoryError(21, "Is a directory", os.fspath(path))
        if not stat.S_ISREG(st.st_mode):
            raise InputFileError(path, f"it is {kind_of(st.st_mode)}, not a file")
        if st.st_size > limit:
            raise InputFileError(path, _too_large(st.st_size, limit, what))
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def _too_large(size: int, limit: int, what: str) -> str:
    return f"it is {_size(size)}; a {what} may be at most {_size(limit)}"


def _size(n: int) -> str:
    return f"{n / MiB:.1f} MiB" if n >= MiB else f"{n} bytes"


def loads_json(text: str | bytes, max_depth: int = MAX_JSON_DEPTH):
    """``json.loads`` that refuses nesting deeper than ``max_depth`` (ValueError, as any JSON
    error) before it parses: the depth is counted over the brackets outside strings."""
    if isinstance(text, bytes):
        text = text.decode("utf-8")
    depth = _depth(text)
    if depth > max_depth:
        raise ValueError(f"arrays and objects are nested {depth} deep; at most {max_depth} are read")
    try:
        return json.loads(text)
    except RecursionError:  # the scan above makes this unreachable; kept as a line, not a traceback
        raise ValueError("arrays and objects are nested too deeply") from None


def _depth(text: str) -> int:
    """The deepest bracket nesting of JSON ``text`` (strings skipped), cheaply: only the
    brackets and quotes are visited."""
    deepest = depth = 0
    in_string = False
    for m in _JSON_MARKS.finditer(text):
        c = m.group()
        if in_string:
            if c == '"':
                in_string = False
            continue
        if c == '"':
            in_string = True
        elif c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth -= 1
    return deepest

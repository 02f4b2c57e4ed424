"""Safe writes: every file the project writes goes through :func:`atomic_write`.

The rules, the same for every writer (plans, motion files, GIFs, PNGs, BVH, CSV, WAVs,
gesture specs, evaluation JSON, corpus shards, weights, the editor's saves):

- **A regular file** (or a new one) is replaced atomically: a temporary file in the same
  folder, ``fsync``, ``os.replace``. A reader or a crash sees the old file or the new one,
  never half of either. (Cache entries are written with ``durable=False``: no ``fsync``, so a
  crash of the machine may leave one empty or short, which its reader treats as a miss.) The file keeps its permissions (a new one gets 0o666 less the umask),
  and a read-only file is refused, not silently replaced.
- **A symbolic link** is followed: its final target is replaced atomically and the link stays
  a link.
- **Anything that is not a regular file** (a character or block device such as ``/dev/null``,
  a FIFO, ``/dev/stdout``, a file reached through ``/proc`` or under ``/sys``) is opened and
  written in place, the way a shell's ``>`` does; it is never renamed over. A FIFO blocks
  until a reader opens it.
- **Missing parent folders are created** (like ``mkdir -p``).
- **A folder, a socket, or a path under a file** raises :class:`OutputPathError`; any other
  failure (permissions, a full disk, a read-only file system) raises :class:`OutputError`.
  Both carry a one-line message for users; both are :class:`OSError`.

:func:`check_output` and :func:`check_output_folder` apply the same rules without writing
anything, so a command can refuse a bad output before it does any work, and
:func:`check_not_input` refuses an output that is one of the command's inputs (the same
file through a link or a hard link too). A file with no write permission for anyone is
read-only even for root.

Standard library only: the ``sgt`` command imports this module to report its errors.
"""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the sgt command imports this module before parsing its arguments: keep it light
    from typing import BinaryIO

#: Folders whose files are written in place (kernel interfaces: renaming over them is meaningless).
_IN_PLACE_ROOTS = ("/proc", "/sys")


class OutputError(OSError):
    """An output that cannot be written; ``str()`` is a one-line message for users."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "cannot write the output"


class OutputPathError(OutputError):
    """The output path names the wrong kind of thing: a folder, a socket, a path under a file."""


def atomic_write(path: Path | str | BinaryIO, data: bytes, *, durable: bool = True) -> None:
    """Write ``data`` to ``path`` by the module's rules; ``path`` may also be a binary stream
    (``sys.stdout.buffer``), which is written and flushed. ``durable=False`` skips the
    ``fsync`` (for cache entries whose readers check them: a process killed mid-write still
    leaves the old file or the new one; only a crash of the machine can leave a short file)."""
    if hasattr(path, "write"):
        try:
            path.write(data)  # type: ignore[union-attr]
            path.flush()  # type: ignore[union-attr]
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OutputError(f"cannot write the output: {exc.strerror or exc}") from None
        return
    shown = _name(path)
    target, in_place = _destination(shown)
    if in_place:
        _write_in_place(target, data, shown)
    else:
        _replace(target, data, shown, durable)


def atomic_write_text(path: Path | str | BinaryIO, text: str) -> None:
    atomic_write(path, text.encode("utf-8"))


def json_text(doc, **options) -> str:
    """``doc`` as JSON text that is always valid UTF-8: other languages' letters as themselves,
    unless some value holds bytes that are not UTF-8 (a file name from a command line or a
    folder listing, which Python keeps as lone surrogates); then the whole text uses ``\\u``
    escapes, which load back to the same name. ``options`` go to :func:`json.dumps`."""
    text = json.dumps(doc, ensure_ascii=False, **options)
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return json.dumps(doc, ensure_ascii=True, **options)
    return text


def json_bytes(doc, **options) -> bytes:
    """:func:`json_text` encoded, for :func:`atomic_write`."""
    return json_text(doc, **options).encode("utf-8")


def check_output(path: Path | str) -> None:
    """Raise :class:`OutputError` if ``path`` cannot be written as a file; writes nothing."""
    shown = _name(path)
    target, in_place = _destination(shown)
    st = _stat(target, shown)
    if st is None:
        _check_new_file(target, shown)
    elif in_place:
        if not os.access(target, os.W_OK):
            raise OutputError(f"cannot write {shown}: permission denied")
    else:
        if _read_only(target, st):
            raise OutputError(f"cannot write {shown}: the file is read-only")
        folder = os.path.dirname(target)
        if not os.access(folder, os.W_OK | os.X_OK):
            raise OutputError(f"cannot write {shown}: permission denied in {folder} (files are replaced atomically there)")


def check_output_folder(path: Path | str) -> None:
    """Raise :class:`OutputError` if ``path`` cannot be (made into) a folder to write files in."""
    shown = _name(path, folder=True)
    try:
        is_folder = stat.S_ISDIR(os.stat(shown).st_mode)
    except FileNotFoundError:
        _check_new_file(os.path.abspath(shown), shown, what="folder")
        return
    except NotADirectoryError:
        raise OutputPathError(f"cannot create the folder {shown}: {_blocker(shown)} is a file") from None
    except OSError as exc:
        raise OutputError(f"cannot write in {shown}: {exc.strerror or exc}") from None
    if not is_folder:
        raise OutputPathError(f"{shown} is a file, not a folder")
    if not os.access(shown, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write in {shown}: permission denied")


def make_folder(path: Path | str) -> Path:
    """Create ``path`` and its parents (nothing if it exists); :class:`OutputError` if impossible."""
    shown = _name(path, folder=True)
    try:
        os.makedirs(shown, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise OutputPathError(f"cannot create the folder {shown}: {_blocker(shown)} is a file") from None
    except OSError as exc:
        raise OutputError(f"cannot create the folder {shown}: {exc.strerror or exc}") from None
    return Path(shown)


# -- internals -----------------------------------------------------------------------------


def _name(path, folder: bool = False) -> str:
    shown = os.fspath(path)
    if isinstance(shown, bytes):
        shown = os.fsdecode(shown)
    if not shown:
        raise OutputPathError("the output file name is empty")
    if "\0" in shown:
        raise OutputPathError(f"{shown!r}: a file name cannot contain a NUL character")
    if not folder and shown.endswith("/") and shown.rstrip("/"):
        raise OutputPathError(f"{shown} names a folder (it ends with '/'); name a file")
    return shown


def _stat(path: str, shown: str) -> os.stat_result | None:
    """``os.stat`` (links followed), None when nothing is there; wrong kinds raise."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return None
    except NotADirectoryError:
        raise OutputPathError(f"cannot write {shown}: {_blocker(path)} is a file, not a folder") from None
    except OSError as exc:
        raise OutputError(f"cannot write {shown}: {exc.strerror or exc}") from None
    if stat.S_ISDIR(st.st_mode):
        raise OutputPathError(f"{shown} is a folder; name a file in it, e.g. {os.path.join(shown, 'NAME')}")
    if stat.S_ISSOCK(st.st_mode):
        raise OutputPathError(f"{shown} is a socket, not a file")
    return st


def _destination(shown: str) -> tuple[str, bool]:
    """(where to write, whether in place): symlinks resolved; in place for non-regular files."""
    target, special = _follow_links(shown)
    st = _stat(shown, shown)
    if st is None:
        return target, special
    if stat.S_ISREG(st.st_mode) and not special:
        return target, False
    return shown, True


def _follow_links(shown: str) -> tuple[str, bool]:
    """The final target of ``shown`` (its folders resolved too), and whether the way there
    passes through ``/proc`` or ``/sys`` (``/dev/stdout`` -> ``/proc/self/fd/1`` -> ...)."""
    cur = os.path.abspath(shown)
    special = _in_place_root(cur)
    for _ in range(40):
        try:
            link = os.readlink(cur)
        except OSError:  # not a link, or nothing there
            break
        cur = os.path.join(os.path.dirname(cur), link)
        special = special or _in_place_root(cur)
    else:
        raise OutputError(f"cannot write {shown}: too many levels of symbolic links")
    try:
        folder = os.path.realpath(os.path.dirname(cur))
    except OSError as exc:
        raise OutputError(f"cannot write {shown}: {exc.strerror or exc}") from None
    cur = os.path.join(folder, os.path.basename(cur))
    return cur, special or _in_place_root(cur)


def _in_place_root(path: str) -> bool:
    return any(path == root or path.startswith(root + "/") for root in _IN_PLACE_ROOTS)


def _blocker(path: str) -> str:
    """The first existing component of ``path`` that is not a folder."""
    parts = Path(os.path.abspath(path)).parts
    for i in range(1, len(parts) + 1):
        p = os.path.join(*parts[:i])
        if os.path.lexists(p) and not os.path.isdir(p):
            return p
    return os.path.dirname(path) or path


def _check_new_file(target: str, shown: str, what: str = "file") -> None:
    """A file (or folder) ``target`` does not exist yet: its nearest existing folder must be writable."""
    folder = os.path.dirname(target)
    while folder and not os.path.lexists(folder):
        parent = os.path.dirname(folder)
        if parent == folder:
            break
        folder = parent
    if os.path.lexists(folder) and not os.path.isdir(folder):
        raise OutputPathError(f"cannot write {shown}: {_blocker(target)} is a file, not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"cannot create the {what} {shown}: permission denied in {folder}")


def _read_only(path: str, st: os.stat_result) -> bool:
    """Whether the regular file ``path`` is read-only: not writable by this process, or with
    no write permission for anyone (root may write such a file; sgt does not replace it)."""
    return not os.access(path, os.W_OK) or not st.st_mode & 0o222


def same_file(a: Path | str, b: Path | str) -> bool:
    """Whether paths ``a`` and ``b`` name one file: the same path once links are resolved, or
    the same inode (a hard link, a bind mount). Nothing that does not exist is anything's twin."""
    try:
        sa, sb = os.stat(a), os.stat(b)
    except (OSError, ValueError):
        return False
    return (sa.st_dev, sa.st_ino) == (sb.st_dev, sb.st_ino)


def check_not_input(output: Path | str, inputs, option: str = "-o") -> None:
    """Raise :class:`OutputPathError` when ``output`` is one of ``inputs`` (the same file, through
    a symbolic or a hard link too): writing it would destroy what the command reads. Devices,
    FIFOs and kernel files are not inputs anyone loses, and are let through."""
    shown = _name(output)
    try:
        st = os.stat(shown)
    except (OSError, ValueError):
        return  # nothing there yet: it cannot be an input
    if not stat.S_ISREG(st.st_mode):
        return
    for source in inputs:
        if source is not None and same_file(shown, source):
            twin = "" if os.path.abspath(os.fspath(source)) == os.path.abspath(shown) else f" (it is {os.fspath(source)})"
            raise OutputPathError(f"{option} {shown}: the output is an input of this command{twin}; writing it would "
                                  f"destroy it: name another file")


def _mode_for(path: str) -> int:
    try:
        return os.stat(path).st_mode & 0o7777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _replace(target: str, data: bytes, shown: str, durable: bool = True) -> None:
    folder = os.path.dirname(target)
    make_folder(folder)
    try:
        st = os.stat(target)
    except OSError:
        st = None
    if st is not None and _read_only(target, st):
        raise OutputError(f"cannot write {shown}: the file is read-only")
    import tempfile

    name = os.path.basename(target)
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{name[:100]}.", suffix=".tmp")
    except OSError as exc:
        raise OutputError(f"cannot write {shown}: {exc.strerror or exc}") from None
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(), _mode_for(target))
            f.write(data)
            f.flush()
            if durable:
                os.fsync(f.fileno())
        os.replace(tmp, target)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise OutputError(f"cannot write {shown}: {exc.strerror or exc}") from None
        raise


def _write_in_place(target: str, data: bytes, shown: str) -> None:
    try:
        with open(target, "wb") as f:
            f.write(data)
    except OSError as exc:
        raise OutputError(f"cannot write {shown}: {exc.strerror or exc}") from None

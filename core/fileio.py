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

- **A file with more than one hard link**, when the writer asks (``keep_hard_links=True``:
  ``sgt fmt`` rewriting a script where it is), is rewritten in place so that every name of it
  sees the new text: the data goes to a temporary file beside it first (``fsync``), then is
  copied into the file itself (``O_TRUNC``, ``fsync``) and the temporary removed. The
  trade-off: that copy is not atomic (a reader may see it half written; a crash in it leaves
  the file short, and the whole text in the temporary ``.NAME.XXXXXXXX.tmp`` beside it).
  A file with one link is replaced atomically as above.

:func:`check_output` and :func:`check_output_folder` apply the same rules without writing
anything, so a command can refuse a bad output before it does any work, and
:func:`check_not_input` refuses an output that is one of the command's inputs (the same
file through a link or a hard link too). A file with no write permission for anyone is
read-only even for root.

**Files nobody named** follow a stricter rule. The rules above are for outputs the user names
(``-o FILE``): links there are the user's and are followed. A file a command writes or
removes that the user did not name (a build's outputs, its manifest, state and lock under
``OUT``; the temporaries and stale outputs it removes there; ``sgt align``'s ``REC.timings.json``
beside a recording, and the language server's) goes through :class:`Inside`: its folder (the
one the user named, or the folder of the input it is derived from) is opened, links in it
followed, and the path below it is walked one component at a time with ``O_NOFOLLOW |
O_DIRECTORY`` relative to the open folder (``dir_fd``). A symbolic link anywhere below the
folder, the last component included, is refused (:class:`LinkRefused`, one line naming the
link), never followed, so the file is always inside its folder: a link planted in ``OUT`` or
beside a recording cannot make sgt write or delete anything elsewhere, even if it appears
while sgt works. ``..``, an absolute path and an empty name are refused too. Writes make a
temporary file with ``O_CREAT | O_EXCL | O_NOFOLLOW`` in the open folder and publish it with
``os.replace`` there (which replaces a link that appeared meanwhile, never its target); where
the command promises never to replace an existing file (``sgt align`` without ``--force``,
the language server's ``sgt.writeTimings``) it is published by ``link`` then ``unlink``, which
fails on anything already there, a dangling link included (:class:`OutputExists`). Removal
opens the file without following links, checks it (a build removes only an unchanged
output) and unlinks it relative to the same open folder. Something that is not a regular
file where such a file goes (a FIFO, a device, a folder) is refused, never written in place.
:func:`resolved_inside` is the same rule for reading a path a file names (a build manifest's
outputs, a motion file's script): the path, links resolved, must be inside the folder.

Standard library only: the ``sgt`` command imports this module to report its errors.
"""

from __future__ import annotations

import errno
import json
import os
import stat
from pathlib import Path
from typing import TYPE_CHECKING, Self

from core.reading import kind_of

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


class LinkRefused(OutputPathError):
    """A symbolic link (or a path leading out) where a command writes, removes or reads a file
    the user did not name (:class:`Inside`, :func:`resolved_inside`): never followed."""


class OutputExists(OutputError):
    """:meth:`Inside.write` with ``exclusive=True`` found something at the path (a dangling link too)."""


def atomic_write(path: Path | str | BinaryIO, data: bytes, *, durable: bool = True, keep_hard_links: bool = False) -> None:
    """Write ``data`` to ``path`` by the module's rules; ``path`` may also be a binary stream
    (``sys.stdout.buffer``), which is written and flushed. ``durable=False`` skips the
    ``fsync`` (for cache entries whose readers check them: a process killed mid-write still
    leaves the old file or the new one; only a crash of the machine can leave a short file).
    ``keep_hard_links=True`` rewrites a file with several hard links in place (see the module
    docstring for the trade-off)."""
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
        _replace(target, data, shown, durable, keep_hard_links)


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
        return _new_file_mode()


def _new_file_mode() -> int:
    """0o666 less the umask, as ``open`` gives a new file."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def _replace(target: str, data: bytes, shown: str, durable: bool = True, keep_hard_links: bool = False) -> None:
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
    linked = keep_hard_links and st is not None and stat.S_ISREG(st.st_mode) and st.st_nlink > 1
    copying = False  # the file itself is being rewritten: the temporary then holds the only whole copy
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(), _mode_for(target))
            f.write(data)
            f.flush()
            if durable or linked:
                os.fsync(f.fileno())
        if linked:  # the same inode, so that its other names see the new text
            copying = True
            with open(target, "r+b") as f:
                f.truncate(0)
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            copying = False
            os.unlink(tmp)
        else:
            os.replace(tmp, target)
    except BaseException as exc:
        if not copying:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        if isinstance(exc, OSError):
            kept = f" (the new text is in {tmp})" if copying else ""
            raise OutputError(f"cannot write {shown}: {exc.strerror or exc}{kept}") from None
        raise


def _write_in_place(target: str, data: bytes, shown: str) -> None:
    try:
        with open(target, "wb") as f:
            f.write(data)
    except OSError as exc:
        raise OutputError(f"cannot write {shown}: {exc.strerror or exc}") from None


# -- files nobody named: inside their folder, links never followed ---------------------------

_TEMP_LETTERS = "abcdefghijklmnopqrstuvwxyz0123456789_"  # tempfile's, so temporaries look alike
_NOFOLLOW_DIR = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC


class Inside:
    """A folder opened for the files a command writes, reads back or removes in it that the
    user did not name (the module docstring's last rule): every path given to its methods is
    relative to the folder, and is walked without following any link.

    ``with Inside(out, create=True) as d: d.write("act1/intro.json", data)``. The folder itself
    is opened as named (its own links followed: the user named it, or it is the folder of an
    input); ``create`` makes it first (like ``mkdir -p``). Paths in messages are
    ``os.path.join(folder, rel)``."""

    def __init__(self, folder: Path | str, *, create: bool = False) -> None:
        self.folder = _name(folder, folder=True)
        if create:
            make_folder(self.folder)
        try:
            self.fd = os.open(self.folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
        except NotADirectoryError:
            raise OutputPathError(f"{self.folder} is a file, not a folder") from None
        except OSError as exc:
            raise OutputError(f"cannot open the folder {self.folder}: {exc.strerror or exc}") from None

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def shown(self, rel: str) -> str:
        return rel if self.folder == os.curdir else os.path.join(self.folder, rel)

    # -- the operations ----------------------------------------------------------------------

    def write(self, rel: str, data: bytes, *, exclusive: bool = False, durable: bool = True) -> None:
        """Write ``data`` to ``rel`` (its missing folders made): atomically replaced; with
        ``exclusive``, only if nothing is there (:class:`OutputExists` otherwise). A link on the
        way or at ``rel`` raises :class:`LinkRefused`; other failures :class:`OutputError`."""
        shown, name, d = self._enter(rel, "write", create=True)
        try:
            st = self._lstat(d, name, shown, "write")
            if st is not None and exclusive:
                raise OutputExists(f"{shown} exists")
            if st is not None and not stat.S_ISREG(st.st_mode):
                raise OutputPathError(f"cannot write {shown}: it is {kind_of(st.st_mode)}, not a file")
            if st is not None and (not st.st_mode & 0o222 or not _access(name, os.W_OK, d)):
                raise OutputError(f"cannot write {shown}: the file is read-only")
            mode = st.st_mode & 0o7777 if st is not None else _new_file_mode()
            tmp = self._temporary(d, name, data, mode, durable, shown)
            try:
                if exclusive:
                    self._publish_new(d, tmp, name, data, mode, shown)
                else:
                    os.replace(tmp, name, src_dir_fd=d, dst_dir_fd=d)
            except BaseException:
                _unlink_quietly(tmp, d)
                raise
        except OSError as exc:
            if isinstance(exc, OutputError):
                raise
            raise OutputError(f"cannot write {shown}: {exc.strerror or exc}") from None
        finally:
            self._done(d)

    def check(self, rel: str) -> None:
        """Raise :class:`LinkRefused` when :meth:`write` would refuse ``rel`` for a link (at it or
        on the way), :class:`OutputPathError` when a folder or a device is there; writes nothing."""
        shown, name, d = self._enter(rel, "write")
        if d is None:
            return
        try:
            st = self._lstat(d, name, shown, "write")
            if st is not None and not stat.S_ISREG(st.st_mode):
                raise OutputPathError(f"cannot write {shown}: it is {kind_of(st.st_mode)}, not a file")
        finally:
            self._done(d)

    def read(self, rel: str, limit: int) -> bytes | None:
        """The bytes of the regular file ``rel`` (None when it is not there), at most ``limit``
        (:class:`OutputError` when larger); a link raises :class:`LinkRefused`."""
        opened = self.open(rel)
        if opened is None:
            return None
        with opened as f:
            data = f.read(limit + 1)
        if len(data) > limit:
            raise OutputError(f"cannot read {self.shown(rel)}: larger than {limit} bytes")
        return data

    def open(self, rel: str):
        """The regular file ``rel`` open for reading (a binary file object), None when it is not
        there; a link on the way raises :class:`LinkRefused`, anything else but a regular
        file :class:`OutputPathError`."""
        shown, name, d = self._enter(rel, "read")
        if d is None:
            return None
        try:
            return self._open_file(d, name, shown, "read")
        finally:
            self._done(d)

    def lstat(self, rel: str) -> os.stat_result | None:
        """The status of ``rel`` itself (a link is not followed, and is what is reported), None
        when nothing is there; a link on the way raises :class:`LinkRefused`."""
        shown, name, d = self._enter(rel, "read")
        if d is None:
            return None
        try:
            return os.stat(name, dir_fd=d, follow_symlinks=False)
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise OutputError(f"cannot read {shown}: {exc.strerror or exc}") from None
        finally:
            self._done(d)

    def remove(self, rel: str, check=None) -> bool:
        """Remove the regular file ``rel`` when ``check(file)`` (given the file open for
        reading) is true or there is no ``check``; True when it was removed, False when it was
        not there or failed the check. A link (on the way or at ``rel``) raises
        :class:`LinkRefused` and nothing is removed."""
        shown, name, d = self._enter(rel, "remove")
        if d is None:
            return False
        try:
            st = self._lstat(d, name, shown, "remove")
            if st is None:
                return False
            if not stat.S_ISREG(st.st_mode):
                raise OutputPathError(f"not removed: {shown} is {kind_of(st.st_mode)}, not a file")
            if check is not None:
                f = self._open_file(d, name, shown, "remove")
                if f is None:
                    return False
                with f:
                    if not check(f):
                        return False
            os.unlink(name, dir_fd=d)  # the name in this folder: a link put there meanwhile is removed, not its target
            return True
        except FileNotFoundError:
            return False
        except OSError as exc:
            if isinstance(exc, OutputError):
                raise
            raise OutputError(f"cannot remove {shown}: {exc.strerror or exc}") from None
        finally:
            self._done(d)

    def entries(self, rel: str) -> list[tuple[str, bool]]:
        """(name, whether it is a regular file) of what is in the folder ``rel`` ("." for the
        folder itself), links not followed; [] when it is not there."""
        shown = self.shown(rel)
        parts = self._parts(rel, folder=True)
        try:
            d = self._walk(parts, shown, "read")
        except FileNotFoundError:
            return []
        try:
            with os.scandir(d) as it:
                return [(e.name, e.is_file(follow_symlinks=False)) for e in it]
        finally:
            self._done(d)

    # -- the walk ----------------------------------------------------------------------------

    def _parts(self, rel: str, folder: bool = False) -> list[str]:
        rel = os.fspath(rel)
        if "\0" in rel:
            raise OutputPathError(f"{rel!r}: a file name cannot contain a NUL character")
        if os.path.isabs(rel):
            raise LinkRefused(f"{rel} is an absolute path; only paths inside {self.folder} are allowed")
        parts = [p for p in rel.replace(os.sep, "/").split("/") if p not in ("", ".")]
        if ".." in parts:
            raise LinkRefused(f"{rel} goes up a folder ('..'); only paths inside {self.folder} are allowed")
        if not parts and not folder:
            raise OutputPathError(f"{self.shown(rel)} names a folder; name a file in it")
        return parts

    def _enter(self, rel: str, what: str, create: bool = False) -> tuple[str, str, int | None]:
        """(``rel`` as shown, its last component, the open folder above it: None when a folder
        on the way is not there, which ``create`` makes)."""
        shown = self.shown(rel)
        parts = self._parts(rel)
        try:
            return shown, parts[-1], self._walk(parts[:-1], shown, what, create)
        except FileNotFoundError as exc:
            if create:  # a folder on the way removed while it was made
                raise OutputError(f"cannot {what} {shown}: {exc.strerror or exc}") from None
            return shown, parts[-1], None

    def _open_file(self, d: int, name: str, shown: str, what: str):
        """The regular file ``name`` in the open folder ``d``, open for reading without following
        a link (a binary file object); None when it is not there."""
        try:
            fd = os.open(name, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC, dir_fd=d)
        except FileNotFoundError:
            return None
        except OSError as exc:
            self._refuse_link(d, name, shown, what, exc)
            raise OutputError(f"cannot read {shown}: {exc.strerror or exc}") from None
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            os.close(fd)
            raise OutputPathError(f"cannot read {shown}: it is {kind_of(st.st_mode)}, not a file")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")

    def _walk(self, parts: list[str], shown: str, what: str, create: bool = False) -> int:
        """The open folder ``parts`` below this one (made when missing with ``create``; else
        FileNotFoundError), reached without following a link."""
        d = self.fd
        for i, part in enumerate(parts):
            try:
                if create:
                    try:
                        os.mkdir(part, 0o777, dir_fd=d)
                    except FileExistsError:
                        pass
                nd = os.open(part, _NOFOLLOW_DIR, dir_fd=d)
            except FileNotFoundError:
                self._done(d)
                raise
            except OSError as exc:
                try:
                    self._refuse_link(d, part, shown, what, exc, os.path.join(self.folder, *parts[: i + 1]))
                    if isinstance(exc, NotADirectoryError):
                        raise OutputPathError(f"cannot {what} {shown}: {os.path.join(self.folder, *parts[: i + 1])} "
                                              f"is a file, not a folder") from None
                    raise OutputError(f"cannot {what} {shown}: {exc.strerror or exc}") from None
                finally:
                    self._done(d)
            self._done(d)
            d = nd
        return d

    def _lstat(self, d: int, name: str, shown: str, what: str) -> os.stat_result | None:
        try:
            st = os.stat(name, dir_fd=d, follow_symlinks=False)
        except FileNotFoundError:
            return None
        if stat.S_ISLNK(st.st_mode):
            raise LinkRefused(_link_refused(what, shown, shown, _readlink(name, d)))
        if stat.S_ISDIR(st.st_mode):
            raise OutputPathError(f"cannot {what} {shown}: it is a folder")
        return st

    def _refuse_link(self, d: int, name: str, shown: str, what: str, exc: OSError, link: str | None = None) -> None:
        """Raise :class:`LinkRefused` when ``exc`` (opening ``name`` without following links)
        was met because ``name`` is a link."""
        if exc.errno in (errno.ELOOP, errno.ENOTDIR, errno.EMLINK):
            try:
                is_link = stat.S_ISLNK(os.stat(name, dir_fd=d, follow_symlinks=False).st_mode)
            except OSError:
                is_link = False
            if is_link:
                raise LinkRefused(_link_refused(what, shown, link or shown, _readlink(name, d))) from None

    def _temporary(self, d: int, name: str, data: bytes, mode: int, durable: bool, shown: str) -> str:
        import secrets

        for _ in range(100):
            tmp = f".{name[:100]}.{''.join(secrets.choice(_TEMP_LETTERS) for _ in range(8))}.tmp"
            try:
                fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600, dir_fd=d)
            except FileExistsError:
                continue
            break
        else:
            raise OutputError(f"cannot write {shown}: no free temporary name beside it")
        try:
            with os.fdopen(fd, "wb") as f:
                os.fchmod(f.fileno(), mode)
                f.write(data)
                f.flush()
                if durable:
                    os.fsync(f.fileno())
        except BaseException:
            _unlink_quietly(tmp, d)
            raise
        return tmp

    def _publish_new(self, d: int, tmp: str, name: str, data: bytes, mode: int, shown: str) -> None:
        """``tmp`` under ``name``, only if nothing is there: a hard link (atomic, whole), or on a
        file system without hard links an exclusive create written in place."""
        try:
            os.link(tmp, name, src_dir_fd=d, dst_dir_fd=d, follow_symlinks=False)
        except FileExistsError:
            raise OutputExists(f"{shown} exists") from None
        except OSError as exc:
            if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOSYS, errno.EMLINK, errno.EXDEV):
                raise
            try:
                fd = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, mode, dir_fd=d)
            except FileExistsError:
                raise OutputExists(f"{shown} exists") from None
            with os.fdopen(fd, "wb") as f:
                f.write(data)
        _unlink_quietly(tmp, d)

    def _done(self, d: int) -> None:
        if d != self.fd:
            os.close(d)


def resolved_inside(folder: Path | str, path: Path | str) -> str:
    """The real path (links resolved) of ``path`` (relative to ``folder``, or absolute), which
    must be inside ``folder`` (itself resolved): :class:`LinkRefused` (one line) for a path
    that leads out of it, by ``..``, an absolute path elsewhere or a link. For reading a path
    that a file names (a build manifest's outputs, a motion file's script)."""
    folder = os.path.realpath(os.fspath(folder))
    path = os.fspath(path)
    if "\0" in path:
        raise LinkRefused(f"{path!r}: a file name cannot contain a NUL character")
    real = os.path.realpath(os.path.join(folder, path))
    if real != folder and not real.startswith(folder.rstrip(os.sep) + os.sep):
        how = "an absolute path" if os.path.isabs(path) else "'..'" if ".." in Path(path).parts else "a link"
        raise LinkRefused(f"{path} leads outside {folder} ({how}, to {real}); only files inside it are read")
    return real


def _link_refused(what: str, shown: str, link: str, dest: str) -> str:
    verb = {"write": "cannot write", "remove": "not removed", "read": "not read"}.get(what, f"cannot {what}")
    who = "it" if link == shown else link
    return f"{verb} {shown}: {who} is a symbolic link (to {dest}), and sgt follows no link to a file you did not name; remove the link"


def _readlink(name: str, d: int) -> str:
    try:
        return os.readlink(name, dir_fd=d)
    except OSError:
        return "?"


def _access(name: str, mode: int, d: int) -> bool:
    try:
        return os.access(name, mode, dir_fd=d, follow_symlinks=False)
    except (OSError, NotImplementedError):
        return True


def _unlink_quietly(name: str, d: int) -> None:
    try:
        os.unlink(name, dir_fd=d)
    except OSError:
        pass

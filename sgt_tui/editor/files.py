"""Opening and saving scripts: UTF-8 checks, line ends kept, atomic saves, changes on disk.

A script that does not exist opens as a new, empty document (created on the first save).
Scripts are read by :func:`core.reading.read_bytes`: only regular files (a FIFO, a device or a
folder is refused by what it is, without blocking on it), at most :data:`core.reading.LIMITS`
``["script"]`` bytes. Saving goes through :func:`core.fileio.atomic_write`, so a reader (or a
crash) sees the old file or the new one, never half of either, after the checks of the output
rule (:meth:`ScriptFile.check_writable`): a read-only file is refused (even as root), and so is
anything that is not a regular file (a FIFO or a device is never written). The file's state on
disk when it was read or last saved is remembered (:class:`DiskState`); a save refuses to
overwrite a file that someone else changed since (:class:`ChangedOnDisk`) unless told to.
"""

from __future__ import annotations

import hashlib
import os
import stat
from dataclasses import dataclass
from pathlib import Path

from core.fileio import OutputError, atomic_write, check_output
from core.reading import InputFileError, kind_of, read_bytes
from dsl.lines import decode_source
from sgt_tui.editor.document import Document

BOM = b"\xef\xbb\xbf"


class FileError(Exception):
    """A script that cannot be opened or saved; the message is for the user."""


class NotAFile(FileError):
    """The path names a folder, a device, a FIFO or a socket: nothing the editor can open."""


class ChangedOnDisk(FileError):
    """The file on disk is no longer what this editor read or saved."""


class TargetExists(FileError):
    """"Save as" would replace another file; the caller asks before overwriting it."""


def check_regular(path: Path, doing: str = "open") -> bool:
    """True when ``path`` is a regular file (through symlinks), False when it does not exist;
    raises :class:`NotAFile` for anything else, without opening it (a FIFO would block)."""
    try:
        mode = path.stat().st_mode
    except (FileNotFoundError, NotADirectoryError):
        return False
    except OSError as exc:
        raise FileError(f"cannot {doing} {path}: {exc.strerror or exc}") from None
    if stat.S_ISREG(mode):
        return True
    link = f" (a link to {os.path.realpath(path)})" if path.is_symlink() else ""
    raise NotAFile(f"cannot {doing} {path}: it is {kind_of(mode)}{link}, not a script file")


def read_script(path: Path, doing: str = "read") -> bytes:
    """The bytes of the script file ``path`` by the rules of :func:`core.reading.read_bytes`
    (regular files only, never blocking on a FIFO; at most the script size limit); raises
    :class:`FileError` (:class:`NotAFile` for a folder, a device, a FIFO) with one line."""
    try:
        return read_bytes(path, "script")
    except IsADirectoryError:
        raise NotAFile(f"cannot {doing} {path}: it is a folder, not a script file") from None
    except InputFileError as exc:
        cls = NotAFile if "not a file" in exc.reason else FileError
        raise cls(f"cannot {doing} {path}: {exc.reason}") from None
    except OSError as exc:
        raise FileError(f"cannot {doing} {path}: {exc.strerror or exc}") from None


@dataclass(frozen=True)
class DiskState:
    """What the file looked like on disk: None fields when it did not exist."""

    mtime_ns: int | None
    size: int | None
    digest: str | None

    @property
    def exists(self) -> bool:
        return self.digest is not None


MISSING = DiskState(None, None, None)


def disk_state(path: Path, previous: DiskState | None = None, data: bytes | None = None) -> DiskState:
    """The file's state now; reuses ``previous``'s digest when mtime and size are unchanged
    (``data``: its bytes, when just read). Something that is not a regular file (a FIFO or a
    device put where the script was) is never read: its digest names what it is."""
    try:
        st = path.stat()
    except (FileNotFoundError, NotADirectoryError):
        return MISSING
    except OSError:
        return MISSING
    if not stat.S_ISREG(st.st_mode):
        return DiskState(None, None, f"not a file: {kind_of(st.st_mode)}")
    if previous is not None and previous.mtime_ns == st.st_mtime_ns and previous.size == st.st_size:
        return previous
    if data is None:
        try:
            data = read_bytes(path, "script")
        except OSError:  # vanished, unreadable, too large: not what was read or saved
            return DiskState(st.st_mtime_ns, st.st_size, "unreadable")
    return DiskState(st.st_mtime_ns, st.st_size, hashlib.sha256(data).hexdigest())


def _newline_of(text: str) -> str:
    if "\r\n" in text:
        return "\r\n"
    if "\n" in text:
        return "\n"
    if "\r" in text:
        return "\r"
    return "\n"


def decode_script(data: bytes, path: Path) -> tuple[str, str, bool]:
    """(text, newline, had BOM) of a script's bytes; raises FileError when not UTF-8."""
    text, bad = decode_source(data)
    if bad is not None:
        start = len(BOM) if data.startswith(BOM) else 0
        raw = data[start:]
        line = raw[:bad].count(b"\n") + 1
        col = bad - (raw.rfind(b"\n", 0, bad) + 1) + 1
        raise FileError(f"{path} is not UTF-8 text (invalid byte 0x{raw[bad]:02x} at line {line}, column {col}); "
                        "sgt scripts are UTF-8: convert it first, e.g. iconv -f latin1 -t utf-8")
    return text, _newline_of(text), data.startswith(BOM)


class ScriptFile:
    """A document and the file it belongs to."""

    def __init__(self, path: Path | str, document: Document, newline: str = "\n", bom: bool = False,
                 disk: DiskState = MISSING) -> None:
        self.path = Path(path)
        self.document = document
        self.newline = newline
        self.bom = bom
        self.disk = disk

    @classmethod
    def open(cls, path: Path | str) -> "ScriptFile":
        """Read ``path``; a missing file gives a new empty document. Raises FileError."""
        path = Path(path)
        if not check_regular(path):
            if path.is_symlink():
                raise FileError(f"{path} is a symlink to {os.readlink(path)}, which does not exist")
            if path.parent != Path("") and not path.parent.is_dir():
                what = "is not a folder" if path.parent.exists() else "does not exist"
                raise FileError(f"cannot create {path}: {path.parent} {what}")
            return cls(path, Document(""))
        data = read_script(path, "open")
        text, newline, bom = decode_script(data, path)
        return cls(path, Document(text), newline, bom, disk_state(path, data=data))

    @property
    def is_new(self) -> bool:
        return not self.disk.exists

    def encoded(self, text: str | None = None) -> bytes:
        text = self.document.text if text is None else text
        data = text.replace("\n", self.newline).encode("utf-8")
        return BOM + data if self.bom else data

    def changed_on_disk(self) -> bool:
        """True when the file on disk differs from what was read or last saved."""
        now = disk_state(self.path, self.disk)
        return now.digest != self.disk.digest

    def read_disk_text(self) -> str:
        """The file's current text on disk (for reloading); raises FileError."""
        return decode_script(read_script(self.path), self.path)[0]

    def reload(self) -> None:
        """Replace the document's text with the file's (one undoable step)."""
        text = self.read_disk_text()
        self.document.set_text(text, label="reload from disk")
        self.document.mark_saved()
        self.disk = disk_state(self.path)

    def check_writable(self, path: Path | None = None) -> None:
        """Raise :class:`FileError` unless ``path`` (default: the script's) can be saved to by
        the output rule, writing nothing: a regular file that is not read-only (for anyone:
        root too), or a new file in a folder that can be written. A FIFO, a device or a folder
        raises :class:`NotAFile`: the editor never writes into one."""
        path = self.path if path is None else path
        check_regular(path, "save")
        try:
            check_output(path)
        except OutputError as exc:  # said as the editor's other save failures are
            text = str(exc)
            raise FileError("cannot save " + text.removeprefix("cannot write ") if text.startswith("cannot write ")
                            else text) from None

    def save(self, *, force: bool = False) -> None:
        """Write the document's text as it is now, atomically. Raises FileError (before anything
        is written) when the file cannot be written by :meth:`check_writable`'s rule,
        ChangedOnDisk when someone else changed the file (unless ``force``)."""
        self.check_writable()
        if not force and self.changed_on_disk():
            now = disk_state(self.path)
            what = "deleted" if not now.exists else "changed"
            raise ChangedOnDisk(f"{self.path} was {what} on disk since it was opened or saved")
        text = self.document.text
        try:
            atomic_write(self.path, self.encoded(text))
        except OutputError as exc:
            raise FileError(str(exc)) from None
        except OSError as exc:
            raise FileError(f"cannot save {self.path}: {exc.strerror or exc}") from None
        self.document.mark_saved(text)
        self.document.break_typing()
        self.disk = disk_state(self.path)

    def save_as(self, path: Path | str, *, overwrite: bool = False) -> None:
        """Save to another path, which becomes this script's path (for a save that failed: a
        read-only folder, a full disk). Raises :class:`TargetExists` when a file is there
        (unless ``overwrite``), :class:`NotAFile` for a folder, a device or a FIFO, FileError
        when it cannot be written (a read-only file among them)."""
        path = Path(path).expanduser()
        exists = check_regular(path, "save as")
        if not path.parent.is_dir():
            what = "is not a folder" if path.parent.exists() else "does not exist"
            raise FileError(f"cannot save as {path}: {path.parent} {what}")
        self.check_writable(path)  # a read-only file is refused before "replace it?" is asked
        if exists and not overwrite and path.resolve() != self.path.resolve():
            raise TargetExists(f"{path} already exists")
        old = self.path, self.disk
        self.path, self.disk = path, disk_state(path)
        try:
            self.save(force=True)
        except FileError:
            self.path, self.disk = old
            raise


def display_name(path: Path) -> str:
    try:
        return str(path.resolve().relative_to(Path(os.getcwd()).resolve()))
    except ValueError:
        return str(path)

"""Recovery files: unsaved work survives a crash or a dropped SSH connection.

While a document has unsaved changes, the editor writes its text every few seconds to a
recovery file in ``$SGT_RECOVERY_DIR`` (default ``~/.cache/sgt/editor/recovery``; see
:func:`editor_cache_dir`), one file per script (named by a hash of its absolute path, so it
never lands in the user's git working tree, and a script of any name has one: the name's
readable part is cut to :data:`NAME_BYTES` bytes, the hash tells scripts apart). Saving or
closing cleanly removes it. When the editor opens a script whose recovery file holds text
that differs from the file, it offers to restore it.

A recovery file that cannot be written (the folder read-only, the disk full) is not silent:
:meth:`RecoveryFile.update` keeps the reason in :attr:`RecoveryFile.problem` (None once a
write succeeds again), which the editor shows once and in its status line, and the next
change tries again.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

from core.fileio import OutputError, atomic_write, json_bytes
from core.paths import cache_dir

FORMAT = "sgt-recovery"
VERSION = 1
#: Seconds between recovery writes while there are unsaved changes.
INTERVAL = 3.0
#: The most bytes of the script's name kept in its recovery file's name (file names are at
#: most 255 bytes; the rest is a hash of the whole path, the ``.json`` and atomic writes' temporaries).
NAME_BYTES = 200


def editor_cache_dir() -> Path:
    """Where the editor keeps its files: ``$SGT_EDITOR_CACHE``, else ``editor`` in the sgt cache
    (:func:`core.paths.cache_dir`)."""
    env = os.environ.get("SGT_EDITOR_CACHE")
    return Path(env).expanduser() if env else cache_dir("editor")


def recovery_dir() -> Path:
    """``$SGT_RECOVERY_DIR``, else ``recovery`` in :func:`editor_cache_dir`."""
    env = os.environ.get("SGT_RECOVERY_DIR")
    return Path(env).expanduser() if env else editor_cache_dir() / "recovery"


@dataclass(frozen=True)
class Recovered:
    text: str
    saved_at: float  # seconds since the epoch
    path: str

    def age(self, now: float | None = None) -> str:
        s = max(0.0, (time.time() if now is None else now) - self.saved_at)
        if s < 90:
            return f"{s:.0f} s ago"
        if s < 5400:
            return f"{s / 60:.0f} min ago"
        if s < 2 * 86400:
            return f"{s / 3600:.0f} h ago"
        return f"{s / 86400:.0f} days ago"


class RecoveryFile:
    """The recovery file of one script."""

    def __init__(self, script: Path | str, directory: Path | None = None) -> None:
        self.script = Path(script).resolve()
        key = hashlib.sha256(str(self.script).encode("utf-8", "surrogateescape")).hexdigest()[:16]
        self.path = (directory or recovery_dir()) / f"{_short(self.script.name)}.{key}.json"
        self.written_version: int | None = None
        self.problem: str | None = None  # why the last write failed (None: it did not)

    def write(self, text: str, version: int | None = None) -> None:
        blob = {"format": FORMAT, "version": VERSION, "path": str(self.script), "saved_at": time.time(), "text": text}
        atomic_write(self.path, json_bytes(blob))
        self.written_version = version

    def load(self) -> Recovered | None:
        """The recovered text, or None when there is none (or it is unreadable)."""
        try:
            blob = json.loads(self.path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(blob, dict) or blob.get("format") != FORMAT or not isinstance(blob.get("text"), str):
            return None
        return Recovered(blob["text"], float(blob.get("saved_at") or 0.0), str(blob.get("path", "")))

    def discard(self) -> None:
        self.written_version = None
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass
        except OSError:
            pass

    def update(self, text: str, version: int, modified: bool) -> bool:
        """Write when the document changed since the last write; remove when nothing is unsaved.

        Returns True when a file was written."""
        if not modified:
            if self.written_version is not None:
                self.discard()
            return False
        if version == self.written_version:
            return False
        try:
            self.write(text, version)
        except OSError as exc:
            self.problem = str(exc) if isinstance(exc, OutputError) else f"cannot write {self.path}: {exc.strerror or exc}"
            return False
        self.problem = None
        return True


def _short(name: str) -> str:
    """``name`` cut to at most :data:`NAME_BYTES` bytes of UTF-8 (whole characters)."""
    raw = name.encode("utf-8", "surrogateescape")
    if len(raw) <= NAME_BYTES:
        return name
    return raw[:NAME_BYTES].decode("utf-8", "ignore")

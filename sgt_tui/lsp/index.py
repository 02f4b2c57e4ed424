"""Where names occur: speakers, gestures and presets in one script, and in the workspace's.

A script is read line by line with the language's own tokens (:func:`sgt_tui.editor.tokens.line_tokens`:
speakers, tags, style tags) and its directives with the language's argument split
(:func:`dsl.directives.split_args`), so references, rename and completion find what the
language reads as a name, and nothing inside a comment or an escape. Scripts on disk are read
again only when their size or time changes; open documents are read from the editor's text.

What the server reads from disk is bounded (docs/editors.md): only regular files under the
workspace's folders, links resolved (a link that leads out of them, or to a device, is
skipped), each through the bounded reader (:func:`core.reading.read_bytes`); the scan of the
folders stops at :data:`MAX_SCRIPTS` scripts, :data:`MAX_ENTRIES` names, :data:`MAX_FOLDERS`
folders or :data:`SCAN_SECONDS`, never follows a folder link, and a workspace folder that is
the file system's root, or no folder, is not scanned at all.
"""

from __future__ import annotations

import logging
import os
import re
import stat
import time
from dataclasses import dataclass
from pathlib import Path

from core.controls import STYLE_NAMES
from core.face import LOOK_DIRECTIONS
from core.reading import MiB, read_bytes
from dsl.directives import split_args
from sgt_tui.editor.tokens import line_tokens

#: The folders a workspace scan never enters.
SKIP_DIRS = frozenset({".git", ".hg", ".svn", "node_modules", "__pycache__", ".venv", "venv", ".tox", ".mypy_cache",
                       ".pytest_cache", "build", "dist", "out"})
#: A workspace scan stops at this many scripts, names (files and folders) looked at, folders
#: entered, or seconds: a huge tree is cut, not crawled.
MAX_SCRIPTS = 2000
MAX_ENTRIES = 50_000
MAX_FOLDERS = 5_000
SCAN_SECONDS = 0.5
#: The largest script of the workspace that is indexed, and the most script text the index
#: holds (an open document is always read whole).
MAX_SCRIPT_BYTES = 4 * MiB
MAX_INDEX_BYTES = 64 * MiB
#: Seconds a workspace's list of scripts is reused before the folders are listed again.
LISTING_TTL = 2.0
log = logging.getLogger("sgt.lsp")
_PER_SPEAKER = ("voice", "rate", "pitch")


@dataclass(frozen=True)
class Occurrence:
    """A name in a script: ``kind`` "speaker", "look" (a speaker a ``[look:NAME]`` names),
    "gesture", "preset" (a use in a style tag), "preset_def" (its ``@preset`` line) or "style"
    (an element, ``speed``); 0-based ``row``, character ``col`` and ``length``."""

    kind: str
    name: str
    row: int
    col: int
    length: int

    def covers(self, row: int, col: int) -> bool:
        return row == self.row and self.col <= col <= self.col + self.length


def occurrences(text: str) -> list[Occurrence]:
    """Every speaker, gesture, preset and style name of a script, in order."""
    out: list[Occurrence] = []
    for row, line in enumerate(text.split("\n")):
        out += line_occurrences(row, line)
    return out


def line_occurrences(row: int, line: str) -> list[Occurrence]:
    tok = line_tokens(line)
    if tok.directive is not None:
        return _directive(row, line[: tok.code_end], line[1 : tok.directive[1]])
    out: list[Occurrence] = []
    if tok.speaker is not None:
        start = tok.speaker[0]
        name = re.match(r"[^\s:]+", line[start:]).group()
        out.append(Occurrence("speaker", name, row, start, len(name)))
    for kind, s, _, payload in tok.items:
        if kind == "tag":
            names, _ = payload
            if len(names) == 2 and names[0][0] == "pose":
                name, at = names[1]
                out.append(Occurrence("gesture", name, row, at, len(name)))
            elif len(names) == 2 and names[0][0] == "look" and names[1][0] not in LOOK_DIRECTIONS:
                name, at = names[1]
                out.append(Occurrence("look", name, row, at, len(name)))  # a speaker, looked at
        elif kind == "style_open":
            for name, _, at, _ in payload:
                out.append(Occurrence("style" if name in STYLE_NAMES else "preset", name, row, at, len(name)))
        elif kind == "style_close" and payload:
            at = line.index(payload[0], s + 2)
            out.append(Occurrence("style" if payload[0] in STYLE_NAMES else "preset", payload[0], row, at, len(payload[0])))
    return out


def _directive(row: int, code: str, name: str) -> list[Occurrence]:
    """The speaker a per-speaker directive names, or the name an ``@preset`` defines (as
    :mod:`dsl.directives` reads them)."""
    args = split_args(code[len(name) + 1 :], row + 1, len(name) + 2)
    if name in _PER_SPEAKER and args:
        first = args[0]
        quoted = first.length > len(first.text)
        if first.text.endswith(":") and len(first.text) > 1:
            return [Occurrence("speaker", first.text[:-1], row, first.col - 1 + quoted, len(first.text) - 1)]
        if len(args) >= 2 and args[1].text == ":":
            return [Occurrence("speaker", first.text, row, first.col - 1 + quoted, len(first.text))]
    if name == "preset" and args:
        preset = args[0].text.partition("=")[0]
        if preset:
            return [Occurrence("preset_def", preset, row, args[0].col - 1, len(preset))]
    return []


class Workspace:
    """The scripts under the workspace's folders and the names in each."""

    def __init__(self) -> None:
        self.roots: list[Path] = []
        self._files: dict[Path, tuple[int, int, list[Occurrence], str]] = {}
        self._held = 0  # characters of script text in _files
        self._listing: tuple[float, list[Path]] = (0.0, [])

    def set_roots(self, roots) -> None:
        """The workspace's folders (links resolved); the file system's root and anything that is
        no folder are left out, with a line on the server's log."""
        self.roots = []
        for r in roots:
            if not r:
                continue
            try:
                path = Path(r).resolve(strict=True)
                folder = stat.S_ISDIR(os.stat(path).st_mode)
            except (OSError, ValueError, RuntimeError):
                log.warning("workspace folder %s left out: it does not exist", r)
                continue
            if not folder or path == Path(path.anchor):
                log.warning("workspace folder %s left out: %s", r, "not a folder" if not folder else "the file system's root")
                continue
            if path not in self.roots:
                self.roots.append(path)
        self._listing = (0.0, [])

    def inside(self, path: Path) -> Path | None:
        """``path`` with its links resolved when that lies under a workspace folder, else None."""
        try:
            real = Path(os.path.realpath(path))
        except (OSError, ValueError):
            return None
        return real if any(real.is_relative_to(root) for root in self.roots) else None

    def scripts(self) -> list[Path]:
        """The ``.sgt`` files under the roots (hidden and build folders skipped, folder links
        not followed), within the scan's bounds."""
        stamp, found = self._listing
        if time.monotonic() - stamp < LISTING_TTL:
            return found
        found = []
        deadline = time.monotonic() + SCAN_SECONDS
        entries = folders = 0
        cut = None
        todo = list(reversed(self.roots))
        while todo and cut is None:
            folder = todo.pop()
            folders += 1
            try:
                with os.scandir(folder) as listing:
                    names = sorted(listing, key=lambda e: e.name)
            except OSError:
                continue
            subfolders = []
            for entry in names:
                entries += 1
                if entry.name.endswith(".sgt"):
                    found.append(Path(entry.path))
                elif entry.is_dir(follow_symlinks=False) and entry.name not in SKIP_DIRS and not entry.name.startswith("."):
                    subfolders.append(entry.path)
            todo += reversed(subfolders)
            if len(found) >= MAX_SCRIPTS:
                cut = f"{MAX_SCRIPTS} scripts"
            elif entries >= MAX_ENTRIES or folders >= MAX_FOLDERS:
                cut = f"{MAX_ENTRIES} names or {MAX_FOLDERS} folders"
            elif time.monotonic() > deadline:
                cut = f"{SCAN_SECONDS} s"
        if cut is not None:
            log.warning("the workspace scan stopped at %s: only the scripts found so far are indexed", cut)
        found = found[:MAX_SCRIPTS]
        listed = set(found)
        self._files = {p: v for p, v in self._files.items() if p in listed}
        self._held = sum(len(v[3]) for v in self._files.values())
        self._listing = (time.monotonic(), found)
        return found

    def read(self, path: Path) -> tuple[str, list[Occurrence]] | None:
        """A script's text on disk and its names (None when it cannot be read: not a regular
        file under the workspace's folders, too large, unreadable)."""
        real = self.inside(path)
        if real is None:
            return None
        try:
            st = os.stat(real)
            if not stat.S_ISREG(st.st_mode) or st.st_size > MAX_SCRIPT_BYTES:
                return None
            hit = self._files.get(path)
            if hit is not None and hit[:2] == (st.st_mtime_ns, st.st_size):
                return hit[3], hit[2]
            if self._held - (len(hit[3]) if hit else 0) + st.st_size > MAX_INDEX_BYTES:
                return None
            data = read_bytes(real, "script", limit=MAX_SCRIPT_BYTES)
        except OSError:
            return None
        text = data.decode("utf-8", errors="replace").replace("\r\n", "\n").replace("\r", "\n")
        found = occurrences(text)
        old = self._files.get(path)
        self._held += len(text) - (len(old[3]) if old else 0)
        self._files[path] = (st.st_mtime_ns, st.st_size, found, text)
        return text, found
    def speakers(self) -> dict[str, int]:
        """Speakers of the workspace's scripts, with how many lines each has."""
        count: dict[str, int] = {}
        for path in self.scripts():
            got = self.read(path)
            if got is None:
                continue
            lines = got[0].split("\n")
            for o in got[1]:
                if o.kind == "speaker" and not lines[o.row].startswith("@"):  # its lines, not its directives
                    count[o.name] = count.get(o.name, 0) + 1
        return count

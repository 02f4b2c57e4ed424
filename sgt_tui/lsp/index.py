"""Where names occur: speakers, gestures and presets in one script, and in the workspace's.

A script is read line by line with the language's own tokens (:func:`sgt_tui.editor.tokens.line_tokens`:
speakers, tags, style tags) and its directives with the language's argument split
(:func:`dsl.directives.split_args`), so references, rename and completion find what the
language reads as a name, and nothing inside a comment or an escape. Scripts on disk are read
again only when their size or time changes; open documents are read from the editor's text.
"""

from __future__ import annotations

import os
import re
import time
from dataclasses import dataclass
from pathlib import Path

from core.controls import STYLE_NAMES
from dsl.directives import split_args
from sgt_tui.editor.tokens import line_tokens

#: The folders a workspace scan never enters.
SKIP_DIRS = frozenset({".git", ".hg", ".svn", "node_modules", "__pycache__", ".venv", "venv", ".tox", ".mypy_cache",
                       ".pytest_cache", "build", "dist", "out"})
#: At most this many scripts are indexed in a workspace (a huge tree is cut, not crawled).
MAX_FILES = 2000
#: Seconds a workspace's list of scripts is reused before the folders are listed again.
LISTING_TTL = 2.0
_PER_SPEAKER = ("voice", "rate", "pitch")


@dataclass(frozen=True)
class Occurrence:
    """A name in a script: ``kind`` "speaker", "gesture", "preset" (a use in a style tag),
    "preset_def" (its ``@preset`` line) or "style" (an element, ``speed``); 0-based ``row``,
    character ``col`` and ``length``."""

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
        self._listing: tuple[float, list[Path]] = (0.0, [])

    def set_roots(self, roots) -> None:
        self.roots = [Path(r) for r in roots if r]
        self._listing = (0.0, [])

    def scripts(self) -> list[Path]:
        """The ``.sgt`` files under the roots (hidden and build folders skipped), at most
        :data:`MAX_FILES`."""
        stamp, found = self._listing
        if time.monotonic() - stamp < LISTING_TTL:
            return found
        found = []
        for root in self.roots:
            for folder, dirs, files in os.walk(root):
                dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS and not d.startswith("."))
                found += [Path(folder) / f for f in sorted(files) if f.endswith(".sgt")]
                if len(found) >= MAX_FILES:
                    break
        found = found[:MAX_FILES]
        self._listing = (time.monotonic(), found)
        return found

    def read(self, path: Path) -> tuple[str, list[Occurrence]] | None:
        """A script's text on disk and its names (None when it cannot be read)."""
        try:
            st = path.stat()
            hit = self._files.get(path)
            if hit is not None and hit[:2] == (st.st_mtime_ns, st.st_size):
                return hit[3], hit[2]
            text = path.read_bytes().decode("utf-8", errors="replace").replace("\r\n", "\n").replace("\r", "\n")
        except OSError:
            return None
        found = occurrences(text)
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

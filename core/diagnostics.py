"""Diagnostics as data: what is wrong, where (file:line:col), what else is involved, how to fix it.

Every problem sgt finds in user input becomes a :class:`Diagnostic` (made by a rule of
:mod:`core.rules`); nothing a user types is allowed to surface as a Python exception. A
diagnostic carries its rule's code and name, a primary span (file, line, col, length), related
spans with their own labels (:class:`Related`, never written into the message), and suggested
fixes as text edits (:class:`Fix`) that an editor or language server can apply. This module is
the only place that renders them: compiler-style text with the source line and a caret, or
JSON data.
"""

from __future__ import annotations

import difflib
import unicodedata
from dataclasses import asdict, dataclass, field
from typing import Iterable, Sequence

from core.counting import plural
from core.fileio import json_text
from core.printable import escaped

ERROR = "error"
WARNING = "warning"
NOTE = "note"


@dataclass(frozen=True)
class Related:
    """A secondary place involved in a diagnostic ("the span opened here"), with its label."""

    message: str
    file: str
    line: int
    col: int
    length: int = 1

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class TextEdit:
    """Replace ``length`` characters at ``line:col`` (1-based, in the diagnostic's file) by ``text``.

    ``length`` 0 inserts; ``text`` "" deletes."""

    line: int
    col: int
    length: int
    text: str

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Fix:
    """A suggested fix: a title for a menu ("replace with 'wave'") and the edits that make it.

    Every edit's position refers to the text as it was diagnosed, and edits do not overlap (as
    in the Language Server Protocol): apply them from the last position to the first."""

    title: str
    edits: tuple[TextEdit, ...]

    def to_dict(self) -> dict:
        return {"title": self.title, "edits": [e.to_dict() for e in self.edits]}


@dataclass(frozen=True)
class Diagnostic:
    """One problem. ``line`` and ``col`` are 1-based (line 0: the whole file); ``length`` is the span to underline."""

    severity: str
    message: str
    file: str = "<string>"
    line: int = 0
    col: int = 0
    length: int = 1
    hint: str | None = None
    code: str = ""  # the rule's code, e.g. "SGT201" (core.rules)
    name: str = ""  # the rule's name, e.g. "unknown-gesture"
    related: tuple[Related, ...] = field(default=())
    fixes: tuple[Fix, ...] = field(default=())

    @property
    def is_error(self) -> bool:
        return self.severity == ERROR

    @property
    def suggestions(self) -> tuple[str, ...]:
        """The replacement texts of the fixes that replace exactly the primary span (the
        "did you mean" choices the hint names), derived from :attr:`fixes`."""
        return tuple(
            f.edits[0].text for f in self.fixes
            if len(f.edits) == 1 and (f.edits[0].line, f.edits[0].col, f.edits[0].length) == (self.line, self.col, self.length)
        )

    @classmethod
    def from_dict(cls, d: dict) -> "Diagnostic":
        """The inverse of :meth:`to_dict` (diagnostics cross processes and files as JSON)."""
        return cls(
            severity=d["severity"], message=d["message"], file=d.get("file", "<string>"), line=int(d.get("line", 0)),
            col=int(d.get("col", 0)), length=int(d.get("length", 1)), hint=d.get("hint"), code=d.get("code", ""),
            name=d.get("name", ""), related=tuple(Related(**r) for r in d.get("related") or ()),
            fixes=tuple(Fix(f["title"], tuple(TextEdit(**e) for e in f.get("edits") or ())) for f in d.get("fixes") or ()),
        )

    def to_dict(self) -> dict:
        return {
            "severity": self.severity,
            "code": self.code,
            "name": self.name,
            "message": self.message,
            "file": self.file,
            "line": self.line,
            "col": self.col,
            "length": self.length,
            "hint": self.hint,
            "suggestions": list(self.suggestions),
            "related": [r.to_dict() for r in self.related],
            "fixes": [f.to_dict() for f in self.fixes],
        }


def suggest(word: str, choices: Iterable[str], n: int = 3) -> list[str]:
    """Close spellings of ``word`` among ``choices`` (for "did you mean ...?")."""
    choices = list(choices)
    found = difflib.get_close_matches(word, choices, n=n, cutoff=0.6)
    if not found:
        low = word.lower()
        found = [c for c in choices if c.lower() == low or c.startswith(low[:4] or "\0")][:n]
    return found


def sort_key(d: Diagnostic):
    return (d.file, d.line, d.col, {ERROR: 0, WARNING: 1, NOTE: 2}.get(d.severity, 3), d.message)


#: Source lines wider than this (in terminal columns) are shown as a window around the caret.
MAX_SOURCE_WIDTH = 100
#: Characters shown as a visible stand-in: controls (U+2400 pictures), bidi and invisible marks.
_HIDDEN = frozenset("\u200b\u200e\u200f\u2060\ufeff\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


def _visible(c: str) -> str:
    """One character as it is echoed in a source excerpt: tabs as a space, control
    characters as their U+24xx picture, bidi and zero-width marks as U+FFFD, so that nothing
    in an excerpt reorders or hides the text around it."""
    if c == "\t":
        return " "
    o = ord(c)
    if o < 0x20:
        return chr(0x2400 + o)
    if o == 0x7F:
        return "\u2421"
    if c in _HIDDEN:
        return "\ufffd"
    return c


def char_width(c: str) -> int:
    """Terminal columns of one (visible) character: 2 for wide East Asian characters and
    emoji, 0 for combining marks and other zero-width characters, else 1."""
    o = ord(c)
    if 0x20 <= o < 0x300:
        return 1
    if unicodedata.combining(c) or unicodedata.category(c) in ("Mn", "Me", "Cf"):
        return 0
    return 2 if unicodedata.east_asian_width(c) in ("W", "F") else 1


def _excerpt_lines(text: str, col: int, length: int, max_width: int = MAX_SOURCE_WIDTH) -> tuple[str, str]:
    """The source line as shown and its caret line (without the gutter), by display width.

    ``col`` (1-based) and ``length`` count characters; the caret and the tildes are placed by
    terminal columns, so wide characters, emoji and combining marks do not shift them. A line
    wider than ``max_width`` is cut to a window around the caret, with "…" where it was cut."""
    chars = [_visible(c) for c in text]
    a = min(max(col - 1, 0), len(chars))
    b = min(a + max(1, length), max(len(chars), a + 1))
    widths = [char_width(c) for c in chars]
    total = sum(widths)
    lo, hi = 0, len(chars)
    if total > max_width:  # keep about a third of the window before the caret
        before = max_width // 3
        lo = a
        w = 0
        while lo > 0 and w + widths[lo - 1] <= before:
            lo -= 1
            w += widths[lo]
        hi = lo
        w = 0
        while hi < len(chars) and w + widths[hi] <= max_width:
            w += widths[hi]
            hi += 1
    shown = ("…" if lo > 0 else "") + "".join(chars[lo:hi]) + ("…" if hi < len(chars) else "")
    pad = (1 if lo > 0 else 0) + sum(widths[lo:a])
    under = max(1, sum(widths[a : min(b, hi)])) if a < len(chars) else 1
    return shown, " " * pad + "^" + "~" * (under - 1)


def format_text(diags: Sequence[Diagnostic], sources: dict[str, str] | None = None, color: bool = False) -> str:
    """Render diagnostics like a compiler: location, message, source line, caret, related
    places (each with its label, source line and caret), hint. (:func:`cap` limits how many.)"""
    out: list[str] = []
    lines_cache: dict[str, list[str]] = {}

    def source_line(file: str, line: int) -> str | None:
        src = (sources or {}).get(file)
        if src is None or not line:
            return None
        lines = lines_cache.get(file)
        if lines is None:  # split each file once, not once per diagnostic
            lines = lines_cache[file] = src.replace("\r\n", "\n").replace("\r", "\n").split("\n")
        return lines[line - 1] if 0 < line <= len(lines) else None

    def excerpt(file: str, line: int, col: int, length: int) -> None:
        text = source_line(file, line)
        if text is None:
            return
        shown, caret = _excerpt_lines(text, col, length)
        out.append(f"  {line:>4} | {shown}")
        out.append(f"       | {caret}")

    for d in diags:
        sev = d.severity
        if color:
            code = {ERROR: "1;31", WARNING: "1;33", NOTE: "1;36"}.get(sev, "1")
            sev = f"\x1b[{code}m{sev}\x1b[0m"
        # names and messages escaped (core.printable): a file named with ESC [2J clears no screen
        where = escaped(f"{d.file}:{d.line}:{d.col}" if d.line else d.file)
        tag = f"[{d.code}] " if d.code.startswith("SGT") else ""
        out.append(f"{where}: {sev}: {tag}{escaped(d.message)}")
        excerpt(d.file, d.line, d.col, d.length)
        for r in d.related:
            rwhere = escaped(f"{r.file}:{r.line}:{r.col}" if r.line else r.file)
            out.append(f"       = note: {rwhere}: {escaped(r.message)}")
            excerpt(r.file, r.line, r.col, r.length)
        if d.hint:
            out.append(f"       = hint: {escaped(d.hint)}")
    return "\n".join(out)


def cap(diags: Sequence[Diagnostic], max_per_file: int | None) -> tuple[list[Diagnostic], dict[str, int]]:
    """The first ``max_per_file`` diagnostics of each file, and how many were left out per file."""
    if not max_per_file or max_per_file <= 0:
        return list(diags), {}
    kept: list[Diagnostic] = []
    seen: dict[str, int] = {}
    left: dict[str, int] = {}
    for d in diags:
        if seen.get(d.file, 0) < max_per_file:
            seen[d.file] = seen.get(d.file, 0) + 1
            kept.append(d)
        else:
            left[d.file] = left.get(d.file, 0) + 1
    return kept, left


def summary(diags: Sequence[Diagnostic]) -> str:
    n_err = sum(d.severity == ERROR for d in diags)
    n_warn = sum(d.severity == WARNING for d in diags)
    parts = []
    if n_err:
        parts.append(plural(n_err, "error"))
    if n_warn:
        parts.append(plural(n_warn, "warning"))
    return ", ".join(parts) if parts else "no problems"


def format_json(diags: Sequence[Diagnostic], max_per_file: int | None = None) -> str:
    """``{"diagnostics": [...], "errors": N, "warnings": N}``; the counts are of all diagnostics,
    and with ``max_per_file`` the list is capped and ``"omitted"`` counts the rest per file."""
    kept, left = cap(diags, max_per_file)
    data = {
        "diagnostics": [d.to_dict() for d in kept],
        "errors": sum(d.severity == ERROR for d in diags),
        "warnings": sum(d.severity == WARNING for d in diags),
    }
    if left:
        data["omitted"] = left
    return json_text(data, indent=2)

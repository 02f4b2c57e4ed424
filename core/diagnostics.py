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
import json
from dataclasses import asdict, dataclass, field
from typing import Iterable, Sequence

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
    """A suggested fix: a title for a menu ("replace with 'wave'") and the edits that make it."""

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
    suggestions: tuple[str, ...] = field(default=())
    name: str = ""  # the rule's name, e.g. "unknown-gesture"
    related: tuple[Related, ...] = field(default=())
    fixes: tuple[Fix, ...] = field(default=())

    @property
    def is_error(self) -> bool:
        return self.severity == ERROR

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


def did_you_mean(word: str, choices: Iterable[str]) -> tuple[str | None, tuple[str, ...]]:
    """A hint sentence and the suggestions, or (None, ()) when nothing is close."""
    found = suggest(word, choices)
    if not found:
        return None, ()
    if len(found) == 1:
        return f"did you mean '{found[0]}'?", tuple(found)
    return "did you mean " + ", ".join(f"'{f}'" for f in found[:-1]) + f" or '{found[-1]}'?", tuple(found)


def sort_key(d: Diagnostic):
    return (d.file, d.line, d.col, {ERROR: 0, WARNING: 1, NOTE: 2}.get(d.severity, 3), d.message)


def format_text(diags: Sequence[Diagnostic], sources: dict[str, str] | None = None, color: bool = False) -> str:
    """Render diagnostics like a compiler: location, message, source line, caret, related
    places (each with its label, source line and caret), hint."""
    out: list[str] = []
    lines_cache: dict[str, list[str]] = {}

    def source_line(file: str, line: int) -> str | None:
        src = (sources or {}).get(file)
        if src is None or not line:
            return None
        lines = lines_cache.get(file)
        if lines is None:  # split each file once, not once per diagnostic
            lines = lines_cache[file] = src.splitlines()
        return lines[line - 1].replace("\t", " ") if 0 < line <= len(lines) else None

    def excerpt(file: str, line: int, col: int, length: int) -> None:
        text = source_line(file, line)
        if text is None:
            return
        out.append(f"  {line:>4} | {text}")
        width = max(1, min(length, max(1, len(text) - col + 1)))
        out.append(f"       | {' ' * (col - 1)}^{'~' * (width - 1)}")

    for d in diags:
        sev = d.severity
        if color:
            code = {ERROR: "1;31", WARNING: "1;33", NOTE: "1;36"}.get(sev, "1")
            sev = f"\x1b[{code}m{sev}\x1b[0m"
        where = f"{d.file}:{d.line}:{d.col}" if d.line else d.file
        tag = f"[{d.code}] " if d.code.startswith("SGT") else ""
        out.append(f"{where}: {sev}: {tag}{d.message}")
        excerpt(d.file, d.line, d.col, d.length)
        for r in d.related:
            rwhere = f"{r.file}:{r.line}:{r.col}" if r.line else r.file
            out.append(f"       = note: {rwhere}: {r.message}")
            excerpt(r.file, r.line, r.col, r.length)
        if d.hint:
            out.append(f"       = hint: {d.hint}")
    return "\n".join(out)


def summary(diags: Sequence[Diagnostic]) -> str:
    n_err = sum(d.severity == ERROR for d in diags)
    n_warn = sum(d.severity == WARNING for d in diags)
    parts = []
    if n_err:
        parts.append(f"{n_err} error{'s' if n_err != 1 else ''}")
    if n_warn:
        parts.append(f"{n_warn} warning{'s' if n_warn != 1 else ''}")
    return ", ".join(parts) if parts else "no problems"


def format_json(diags: Sequence[Diagnostic]) -> str:
    return json.dumps(
        {
            "diagnostics": [d.to_dict() for d in diags],
            "errors": sum(d.severity == ERROR for d in diags),
            "warnings": sum(d.severity == WARNING for d in diags),
        },
        indent=2,
        ensure_ascii=False,
    )

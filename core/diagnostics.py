"""Diagnostics: what is wrong, where (file:line:col) and how to fix it.

Every problem the language front end finds becomes a :class:`Diagnostic`; nothing a user
types is allowed to surface as a Python exception. The same objects render as compiler-style
text (with the source line and a caret) or as JSON data for editors.
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
class Diagnostic:
    """One problem. ``line`` and ``col`` are 1-based; ``length`` is the span to underline."""

    severity: str
    message: str
    file: str = "<string>"
    line: int = 0
    col: int = 0
    length: int = 1
    hint: str | None = None
    code: str = ""
    suggestions: tuple[str, ...] = field(default=())

    @property
    def is_error(self) -> bool:
        return self.severity == ERROR

    def to_dict(self) -> dict:
        d = asdict(self)
        d["suggestions"] = list(self.suggestions)
        return d


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
    """Render diagnostics like a compiler: location, message, source line, caret, hint."""
    out: list[str] = []
    lines_cache: dict[str, list[str]] = {}
    for d in diags:
        sev = d.severity
        if color:
            code = {ERROR: "1;31", WARNING: "1;33", NOTE: "1;36"}.get(sev, "1")
            sev = f"\x1b[{code}m{sev}\x1b[0m"
        where = f"{d.file}:{d.line}:{d.col}" if d.line else d.file
        out.append(f"{where}: {sev}: {d.message}")
        src = (sources or {}).get(d.file)
        if src is not None and d.line:
            lines = lines_cache.get(d.file)
            if lines is None:  # split each file once, not once per diagnostic
                lines = lines_cache[d.file] = src.splitlines()
            if 0 < d.line <= len(lines):
                text = lines[d.line - 1].replace("\t", " ")
                out.append(f"  {d.line:>4} | {text}")
                width = max(1, min(d.length, max(1, len(text) - d.col + 1)))
                caret = "^" + "~" * (width - 1)
                out.append(f"       | {' ' * (d.col - 1)}{caret}")
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

"""Split a script into statements: utterances and ``@directives``.

Rules (see docs/language.md):

- one utterance per line; a line that starts with spaces or tabs continues the previous one;
- ``#`` starts a comment that runs to the end of the line (``\\#`` is a literal ``#``);
- blank and comment-only lines are ignored; UTF-8, an optional BOM, CRLF or LF line ends;
- a line starting with ``@`` is a directive;
- an utterance may start with ``speaker:`` (a name followed by a colon and a space).

Each statement keeps a map from its text offsets back to file line and column so that every
diagnostic points at the right character.
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass, field

SPEAKER_RE = re.compile(r"[ \t]*([A-Za-z_][A-Za-z0-9_\-]*)[ \t]*:(?=[ \t]|$)")


@dataclass
class Statement:
    kind: str  # "utterance" or "directive"
    text: str  # comments removed, continuation lines joined with "\n"
    line: int  # first line (1-based)
    speaker: str | None = None
    speaker_col: int = 0
    body_offset: int = 0  # where the utterance body starts in ``text``
    # parallel lists: text offset where a piece starts -> (line, col of that offset)
    _starts: list[int] = field(default_factory=list)
    _lines: list[int] = field(default_factory=list)
    _cols: list[int] = field(default_factory=list)

    def add_piece(self, offset: int, line: int, col: int) -> None:
        self._starts.append(offset)
        self._lines.append(line)
        self._cols.append(col)

    def position(self, offset: int) -> tuple[int, int]:
        """File (line, col), 1-based, of character ``offset`` of :attr:`text`."""
        if len(self._starts) == 1:  # most statements are one line
            return self._lines[0], self._cols[0] + offset
        i = max(0, bisect.bisect_right(self._starts, offset) - 1)
        return self._lines[i], self._cols[i] + (offset - self._starts[i])

    @property
    def origin(self) -> tuple[int, int] | None:
        """For a one-line statement, the (line, col) of offset 0 (a column is then the offset
        plus that col); None when it has continuation lines."""
        return (self._lines[0], self._cols[0]) if len(self._starts) == 1 else None

    @property
    def last_line(self) -> int:
        return self._lines[-1] if self._lines else self.line


def decode_source(data: bytes) -> tuple[str, int | None]:
    """Decode UTF-8 (BOM allowed). Returns (text, None) or (text with replacements, bad byte offset)."""
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8"), None
    except UnicodeDecodeError as exc:
        return data.decode("utf-8", errors="replace"), exc.start


def strip_comment(line: str) -> str:
    """The line without its comment; an escaped ``\\#`` is kept."""
    if "#" not in line:
        return line
    i = 0
    n = len(line)
    while i < n:
        c = line[i]
        if c == "\\":
            i += 2
            continue
        if c == "#":
            return line[:i]
        i += 1
    return line


def split_lines(source: str) -> list[str]:
    """Lines without their ends; CRLF, CR and LF all end a line."""
    return source.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def split_statements(source: str) -> tuple[list[Statement], list[tuple[int, int, str]]]:
    """Statements of ``source`` and layout problems as (line, col, message)."""
    statements: list[Statement] = []
    problems: list[tuple[int, int, str]] = []
    current: Statement | None = None
    for number, raw in enumerate(split_lines(source), start=1):
        code = strip_comment(raw)
        if not code.strip():
            continue
        indented = code[0] in " \t"
        if indented:
            if current is None or current.kind != "utterance":
                what = "a directive" if current is not None else "nothing"
                problems.append((number, 1, f"indented line continues {what}: only utterances may continue on indented lines"))
                continue
            stripped = code.lstrip(" \t")
            col = len(code) - len(stripped) + 1
            current.text += "\n"
            current.add_piece(len(current.text), number, col)
            current.text += stripped.rstrip()
            continue
        current = Statement(kind="directive" if code.startswith("@") else "utterance", text="", line=number)
        current.add_piece(0, number, 1)
        current.text = code.rstrip()
        if current.kind == "utterance":
            m = SPEAKER_RE.match(current.text)
            if m:
                current.speaker = m.group(1)
                current.speaker_col = m.start(1) + 1
                current.body_offset = m.end()
        statements.append(current)
    return statements, problems

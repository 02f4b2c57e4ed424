"""Split a script into statements: utterances and ``@directives``.

Rules (see docs/language.md):

- one utterance per line; a line that starts with spaces or tabs continues the previous one;
- ``#`` starts a comment that runs to the end of the line (``\\#`` is a literal ``#``);
- blank and comment-only lines are ignored; UTF-8, an optional BOM, CRLF or LF line ends;
- a line starting with ``@`` is a directive;
- an utterance may start with ``speaker:``: one word (letters of any alphabet, digits, ``_``
  and ``-``, not starting with a digit), a colon, then a space or the end of the line.

Lines that look like a speaker but are not one get a warning: two or three words before the
colon (``mall guide: Hello``, spoken whole) and a colon with no space after it, before a
word or a mark (``g:hello``, ``guide:[pose:nod] Yes.``: the name is spoken as text).
Escaping the colon (``\\:``) says "this is text" and silences both.

Each statement keeps a map from its text offsets back to file line and column so that every
diagnostic points at the right character.
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass, field

from core import rules
from core.diagnostics import Diagnostic, Fix, TextEdit

_NAME = r"[^\W\d][\w\-]*"
SPEAKER_RE = re.compile(rf"[ \t]*({_NAME})[ \t]*:(?=[ \t]|$)")
#: Two or three words and a colon at the start of a line: a speaker name with a space?
_SPACED_SPEAKER_RE = re.compile(rf"({_NAME}(?:[ \t]+[\w\-]+){{1,2}})[ \t]*:(?=[ \t]|$)")
#: A name, a colon and a word, a tag or a style tag with no space between: a speaker without its space?
_GLUED_SPEAKER_RE = re.compile(rf"({_NAME}):([^\W\d_][\w\-']*|\[[^\[\]]*\]|</?[^<>\[\]]*>)")


@dataclass
class Statement:
    kind: str  # "utterance" or "directive"
    text: str  # comments removed, continuation lines joined with "\n"
    line: int  # first line (1-based)
    speaker: str | None = None
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


def utf16_order(data: bytes) -> str | None:
    """"little-endian" or "big-endian" when ``data`` looks like UTF-16 text (a UTF-16 byte-order
    mark, or NUL bytes in most odd or even positions), else None."""
    if data.startswith(b"\xff\xfe"):
        return "little-endian"
    if data.startswith(b"\xfe\xff"):
        return "big-endian"
    sample = data[:2000]
    if len(sample) < 4:
        return None
    odd, even = sample[1::2], sample[0::2]
    if odd.count(0) > 0.6 * len(odd) and even.count(0) < 0.1 * len(even):
        return "little-endian"
    if even.count(0) > 0.6 * len(even) and odd.count(0) < 0.1 * len(odd):
        return "big-endian"
    return None


def split_statements(source: str, file: str = "<string>") -> tuple[list[Statement], list[Diagnostic]]:
    """Statements of ``source`` and the layout problems (indentation, lines that look like a
    speaker but are not) as diagnostics in ``file``."""
    statements: list[Statement] = []
    problems: list[Diagnostic] = []
    current: Statement | None = None
    for number, raw in enumerate(split_lines(source), start=1):
        code = strip_comment(raw)
        if not code.strip():
            continue
        indented = code[0] in " \t"
        if indented:
            if current is None or current.kind != "utterance":
                what = "a directive" if current is not None else "nothing"
                problems.append(rules.INDENT.at(file, number, 1, 1, what=what))
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
                current.body_offset = m.end()
            else:
                _speaker_lookalike(current.text, file, number, problems)
        statements.append(current)
    return statements, problems


def _speaker_lookalike(text: str, file: str, line: int, problems: list[Diagnostic]) -> None:
    """Warn when a line that has no speaker starts like one (see the module docstring)."""
    if ":" not in text:
        return
    m = _SPACED_SPEAKER_RE.match(text)
    if m:
        name = m.group(1)
        fixed = re.sub(r"[ \t]+", "_", name)
        colon = text.index(":", m.end(1))
        problems.append(rules.SPEAKER_SPACE.at(file, line, 1, len(name), text=name, fixed=fixed, fixes=(
            Fix(f"make '{fixed}' the speaker", (TextEdit(line, 1, len(name), fixed),)),
            Fix("speak the colon", (TextEdit(line, colon + 1, 1, "\\:"),)),
        )))
        return
    m = _GLUED_SPEAKER_RE.match(text)
    if m and not text.startswith(("http:", "https:", "mailto:")):
        name, rest = m.group(1), m.group(2)
        colon = m.end(1)
        problems.append(rules.SPEAKER_COLON.at(file, line, 1, m.end(), name=name, rest=rest, fixes=(
            Fix(f"make '{name}' the speaker", (TextEdit(line, colon + 2, 0, " "),)),
            Fix("speak it as written", (TextEdit(line, colon + 1, 1, "\\:"),)),
        )))

"""What BML and SSML become in sgt: a script's utterances built from text and marks, the
problems met on the way (one line each, at the file's line and column), and the mapping a
user gives from lexemes or mark names to sgt marks (``sgt import --map FILE``)."""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass

from dsl.lines import SPEAKER_RE
from dsl.plain import escape

#: What a mapping's value may be: a pose or a look mark's inside, as a script writes it.
_MARK = re.compile(r"(pose|look):[^\s\[\]<>\\#]+(?: [^\[\]<>\\#]+)?")


@dataclass(frozen=True)
class Problem:
    """Something that could not be imported, at ``file``:``line``:``col``; a warning keeps the
    rest of its element (its text)."""

    file: str
    line: int
    col: int
    message: str
    warning: bool = False

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}: {'warning' if self.warning else 'error'}: {self.message}"


@dataclass
class Utterance:
    """One line of the script: its speaker (None: the default one) and its pieces in order:
    ``("text", str)`` spoken as it is, ``("mark", str)`` written as it is."""

    speaker: str | None
    pieces: list
    file: str
    line: int
    col: int


class MarkMap(dict):
    """Lexeme or mark name -> the sgt mark it becomes (``pose:wave x2``, ``look:left``)."""


def load_mark_map(text: str, file: str) -> tuple[MarkMap, list[Problem]]:
    """A mapping file: TOML, each key a lexeme or an SSML mark's name, each value a mark
    (``"deictic=you" = "pose:point_front"``, ``there = "look:left"``)."""
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"\(at line (\d+), column (\d+)\)", str(exc))
        line, col = (int(m.group(1)), int(m.group(2))) if m else (1, 1)
        return MarkMap(), [Problem(file, line, col, f"not a TOML mapping: {str(exc).split(' (at line')[0]}")]
    out, problems = MarkMap(), []
    lines = text.splitlines()
    for key, value in table.items():
        if isinstance(value, str) and _MARK.fullmatch(value.strip()):
            out[key] = value.strip()
            continue
        line = next((n + 1 for n, t in enumerate(lines) if t.lstrip().startswith((key, f'"{key}"', f"'{key}'"))), 1)
        problems.append(Problem(file, line, 1, f"'{key}' maps to {value!r}: write a mark as a script does, "
                                               "\"pose:NAME [x2] [flip] [hold=500ms]\" or \"look:TARGET\""))
    return out, problems


def mark_for(name: str, marks: MarkMap, library) -> str | None:
    """The mark an SSML mark's name stands for: the mapping's, the name written as a mark
    (``pose:wave x2``, ``look:left``), or a gesture's name; None when it is none of these."""
    if name in marks:
        return f"[{marks[name]}]"
    if _MARK.fullmatch(name.strip()):
        return f"[{name.strip()}]"
    if name in library:
        return f"[pose:{name}]"
    return None


def script_text(utterances: list[Utterance], speaker: str = "agent") -> tuple[str, list[Problem]]:
    """The script's lines (``speaker: text [marks]``), and the speakers it cannot write."""
    lines, problems = [], []
    for u in utterances:
        who = u.speaker or speaker
        if not SPEAKER_RE.fullmatch(f"{who}:"):
            problems.append(Problem(u.file, u.line, u.col, f"'{who}' is not a speaker name sgt can write "
                                                           "(letters, digits, '_' and '-', not starting with a digit)"))
            continue
        body = []
        for kind, value in u.pieces:
            if kind == "mark":
                body.append(f" {value} ")
            elif value.strip():
                body.append((" " if value[0].isspace() else "") + escape(value) + (" " if value[-1].isspace() else ""))
            else:
                body.append(" " if value else "")
        lines.append(f"{who}: " + re.sub(r"\s+(?=[,.;:!?])", "", " ".join("".join(body).split())))
    return "".join(line + "\n" for line in lines), problems

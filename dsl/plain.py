"""Plain text as a script, and the paths a script would read.

- :func:`plain_script` turns text an agent wants spoken (an LLM's answer, a line of dialogue)
  into a one-utterance script: every character the language reads specially is escaped, so the
  text is spoken as it is (tags, ``#``, ``@`` and colons included), with optional voice, rate,
  pitch and style settings.
- :func:`file_references` lists the files and folders a script's ``@audio`` (and its
  ``timings=``) and ``@library`` directives name, where they are written, without touching
  the file system: a service checks them against its allow-list before anything is read.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from dsl.directives import split_args
from dsl.lines import SPEAKER_RE, split_statements

#: Characters the language reads specially inside an utterance (docs/language.md, "Literal characters").
_SPECIAL = re.compile(r"([\\\[\]<>#:])")


def escape(text: str) -> str:
    """``text`` with every special character escaped and line breaks made spaces: spoken as is."""
    return _SPECIAL.sub(r"\\\1", " ".join(text.split()))


def plain_script(text: str, *, speaker: str = "agent", voice: str | None = None, rate: int | None = None,
                 pitch: int | None = None, style: dict[str, float] | None = None) -> str:
    """A script that speaks ``text`` as one utterance of ``speaker``; ``style`` (element -> value)
    applies to the whole utterance. Raises ValueError for a speaker name the language rejects."""
    return utterance_script(escape(text), speaker=speaker, voice=voice, rate=rate, pitch=pitch, style=style)


def utterance_script(body: str, *, speaker: str = "agent", voice: str | None = None, rate: int | None = None,
                     pitch: int | None = None, style: dict[str, float] | None = None) -> str:
    """:func:`plain_script` for a ``body`` already written in the language (marks kept)."""
    if not SPEAKER_RE.fullmatch(f"{speaker}:") or speaker != speaker.strip():
        raise ValueError(f"'{speaker}' is not a speaker name: use letters, digits, '_' and '-', not starting with a digit")
    lines = []
    if voice is not None:
        lines.append(f"@voice {voice}")
    if rate is not None:
        lines.append(f"@rate {rate}")
    if pitch is not None:
        lines.append(f"@pitch {pitch}")
    if style:
        body = "<" + " ".join(f"{name}:{value:+g}" for name, value in style.items()) + ">" + body
    lines.append(f"{speaker}: {body}")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class FileReference:
    """A path a directive names: ``kind`` is "audio", "timings" or "library"; ``line``/``col``/
    ``length`` locate the path's text in the script (1-based)."""

    kind: str
    text: str
    line: int
    col: int
    length: int


def file_references(source: str) -> list[FileReference]:
    """Every path an ``@audio`` or ``@library`` directive of ``source`` names (tokenised as the
    compiler does), malformed directives included; reads no file."""
    refs: list[FileReference] = []
    statements, _ = split_statements(source)
    for st in statements:
        if st.kind != "directive":
            continue
        m = re.match(r"@([A-Za-z_][A-Za-z0-9_\-]*)?", st.text)
        name = m.group(1) if m else None
        if name not in ("audio", "library"):
            continue
        args = split_args(st.text[m.end():], st.line, m.end() + 1)
        for i, arg in enumerate(args):
            key, sep, value = arg.text.partition("=")
            if name == "audio" and i > 0 and sep:
                refs.append(FileReference("timings", value, st.line, arg.col + len(key) + 1, len(value)))
            elif i == 0 or name == "library":
                refs.append(FileReference(name, arg.text, st.line, arg.col, arg.length))
    return refs

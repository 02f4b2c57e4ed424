"""Request bodies, and turning one into a script whose paths the service may read.

A request is a script (``script``) or plain text (``text``, with ``speaker``, ``voice``,
``rate``, ``pitch`` and ``style`` defaults: :func:`dsl.plain.plain_script`). Paths in a script
(``@audio``, its ``timings=``, ``@library``) are checked against the allow-list before the
compiler sees the script, so a refused path is never opened: the answer does not even say
whether it exists (rule SGT406).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from core import rules
from core.controls import STYLE_LIMIT
from core.seeds import SEED_MAX
from dsl.plain import file_references, plain_script
from model.engines import DEFAULT_ENGINE, ENGINES

#: The name diagnostics give a request's script.
REQUEST_FILE = "<request>"
OUTPUTS = ("bvh", "glb", "wav")
AUDIO_SUFFIXES = (".wav", ".flac", ".mp3")


class Style(BaseModel):
    model_config = ConfigDict(extra="forbid")
    speed: float | None = Field(None, ge=-STYLE_LIMIT, le=STYLE_LIMIT)
    space: float | None = Field(None, ge=-STYLE_LIMIT, le=STYLE_LIMIT)
    handedness: float | None = Field(None, ge=-STYLE_LIMIT, le=STYLE_LIMIT)

    def values(self) -> dict[str, float]:
        return {k: v for k, v in self.model_dump().items() if v is not None}


class Word(BaseModel):
    model_config = ConfigDict(extra="forbid")
    word: str = Field(min_length=1, max_length=200)
    start: float = Field(ge=0, allow_inf_nan=False)
    end: float = Field(ge=0, allow_inf_nan=False)


class TextSettings(BaseModel):
    """What a plain text is spoken with."""

    model_config = ConfigDict(extra="forbid")
    speaker: str = Field("agent", min_length=1, max_length=64)
    voice: str | None = Field(None, min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_+\-]+$")
    rate: int | None = Field(None, ge=80, le=450)
    pitch: int | None = Field(None, ge=0, le=100)
    style: Style | None = None


class CheckRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    script: str = Field(max_length=1_000_000)


class GenerateRequest(TextSettings):
    """``POST /v1/generate``: a script or a text; with a recording (multipart), the text is its transcript."""

    script: str | None = Field(None, max_length=1_000_000, description="an .sgt script")
    text: str | None = Field(None, max_length=1_000_000, description="plain text, spoken as is")
    seed: int | None = Field(None, ge=0, le=SEED_MAX)
    engine: Literal[tuple(ENGINES)] = DEFAULT_ENGINE  # type: ignore[valid-type]
    timing: Literal["speech", "estimate"] = "speech"
    utterances: list[int] | None = Field(None, max_length=1000)
    outputs: list[Literal[OUTPUTS]] = Field(default_factory=list, max_length=3)  # type: ignore[valid-type]
    words: list[Word] | None = Field(None, max_length=5000, description="word timings of an uploaded recording")

    @model_validator(mode="after")
    def _one_source(self):
        if (self.script is None) == (self.text is None):
            raise ValueError("give exactly one of 'script' (an .sgt script) and 'text' (plain text)")
        if self.script is not None:
            given = [k for k in ("voice", "rate", "pitch", "style") if getattr(self, k) is not None]
            if given or "speaker" in self.model_fields_set:
                raise ValueError(f"{', '.join(given or ['speaker'])} apply to 'text'; a script sets them itself "
                                 "(@voice, @rate, @pitch, <style> tags)")
        if self.text is not None and self.utterances is not None:
            raise ValueError("'utterances' picks utterances of a script; a text is one utterance")
        return self


class RequestError(Exception):
    """A request the service refuses: ``status`` and the diagnostics (or a message) to answer."""

    def __init__(self, status: int, message: str, diagnostics=()) -> None:
        super().__init__(message)
        self.status = status
        self.diagnostics = list(diagnostics)


def text_script(req: TextSettings, text: str, audio: str | None = None, timings: str | None = None) -> str:
    """The script for a plain text; with a recording, its ``@audio`` line first (server-made paths)."""
    try:
        script = plain_script(text, speaker=req.speaker, voice=req.voice, rate=req.rate, pitch=req.pitch,
                              style=req.style.values() if req.style else None)
    except ValueError as exc:
        raise RequestError(422, str(exc)) from None
    if audio is None:
        return script
    audio_line = f"@audio {audio}" + (f" timings={timings}" if timings else "")
    *header, utterance = script.rstrip("\n").split("\n")
    return "\n".join([*header, audio_line, utterance]) + "\n"


def refused_paths(source: str, allow: tuple[Path, ...]) -> list:
    """SGT406 diagnostics for the paths of ``source`` outside the allowed folders (relative
    paths resolve against the first). Links are resolved first; nothing is opened."""
    out = []
    for ref in file_references(source):
        directive = "library" if ref.kind == "library" else "audio"
        if not allow:
            reason = "this service reads no files named in requests (it was started without --allow)"
        else:
            try:  # as the compiler resolves it (dsl.directives): ~ expanded, relative to the script's folder
                path = Path(ref.text).expanduser()
                if not path.is_absolute():
                    path = allow[0] / path
                resolved = path.resolve()
            except (OSError, RuntimeError, ValueError):  # a link loop, a NUL byte
                resolved = None
            if resolved is not None and any(resolved.is_relative_to(folder) for folder in allow):
                continue
            reason = "it is outside the folders this service allows"
        out.append(rules.REFUSED_PATH.at(REQUEST_FILE, ref.line, ref.col, ref.length, text=ref.text, reason=reason,
                                         directive=directive))
    return out

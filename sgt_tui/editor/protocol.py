"""What the editor and its worker process say to each other: typed requests, results and events.

One JSON object a line each way (:mod:`sgt_tui.editor.worker` documents the exchange). Both
sides build and read these dataclasses, never raw dicts, so a field's name and type are written
down once; :func:`decode_event` turns a line the worker wrote back into an event, or None for a
line that is not one (the reader skips it).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

from core.diagnostics import Diagnostic

OPS = ("generate", "render")
PHASES = ("speech", "motion", "render")


class ProtocolError(ValueError):
    """A request the worker cannot read (reported back as an error event)."""


@dataclass(frozen=True)
class JobRequest:
    """Generate motion for a script's text (``render``: and a GIF of it)."""

    op: str  # "generate" or "render"
    path: str = ""  # the script: names in it (@library, @audio) resolve against its folder
    source: str = ""  # the editor's text, unsaved edits included
    engine: str = "rules"
    weights: str | None = None  # the neural engine's weights (None: the shipped file)
    utterances: tuple[int, ...] | None = None  # 0-based indices; None: every utterance
    out: str | None = None  # where the motion is saved (NPZ)
    gif: str | None = None  # render: the GIF to write
    size: tuple[int, int] = (320, 320)  # render: GIF size in pixels
    seed: int | None = None
    timing: str = "speech"  # "speech" (espeak-ng or recordings) or "estimate"

    def to_dict(self) -> dict:
        d = asdict(self)
        d["utterances"] = None if self.utterances is None else list(self.utterances)
        d["size"] = list(self.size)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "JobRequest":
        if not isinstance(d, dict) or d.get("op") not in OPS:
            raise ProtocolError(f"unknown request {d.get('op') if isinstance(d, dict) else d!r}")
        known = {k: v for k, v in d.items() if k in cls.__dataclass_fields__}
        if known.get("utterances") is not None:
            known["utterances"] = tuple(int(i) for i in known["utterances"])
        if known.get("size") is not None:
            w, h = known["size"]
            known["size"] = (int(w), int(h))
        return cls(**known)


@dataclass(frozen=True)
class JobResult:
    utterances: tuple[int, ...] = ()  # indices of the generated utterances, in order
    frames: int = 0
    timing: str | None = None  # the speech engine that timed the words
    motion: str | None = None  # the saved motion file
    gif: str | None = None
    gif_frames: int = 0

    def to_dict(self) -> dict:
        d = asdict(self)
        d["utterances"] = list(self.utterances)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "JobResult":
        known = {k: v for k, v in (d or {}).items() if k in cls.__dataclass_fields__}
        known["utterances"] = tuple(int(i) for i in known.get("utterances") or ())
        return cls(**known)


@dataclass(frozen=True)
class Progress:
    id: str
    phase: str  # one of PHASES
    done: int
    total: int
    what: str = ""


@dataclass(frozen=True)
class Done:
    id: str
    result: JobResult


@dataclass(frozen=True)
class Failed:
    id: str | None
    message: str
    diagnostics: tuple[Diagnostic, ...] = field(default=())


Event = Progress | Done | Failed


def encode_request(rid: str, request: JobRequest) -> str:
    return json.dumps(dict(request.to_dict(), id=rid), ensure_ascii=False)


def encode_event(event: Event) -> str:
    if isinstance(event, Progress):
        d = dict(asdict(event), event="progress")
    elif isinstance(event, Done):
        d = {"id": event.id, "event": "done", "result": event.result.to_dict()}
    else:
        d = {"id": event.id, "event": "error", "message": event.message,
             "diagnostics": [x.to_dict() for x in event.diagnostics]}
    return json.dumps(d, ensure_ascii=False)


def decode_event(line: str) -> Event | None:
    """The event on one line of the worker's output; None for a line that is not an event. An
    event whose payload cannot be read fails its job (with why) instead of leaving it running."""
    try:
        d = json.loads(line)
    except ValueError:
        return None
    if not isinstance(d, dict) or d.get("event") not in ("progress", "done", "error"):
        return None
    rid = d.get("id")
    try:
        kind = d["event"]
        if kind == "progress":
            return Progress(str(rid), str(d.get("phase", "")), int(d.get("done", 0)), int(d.get("total", 0)),
                            str(d.get("what", "")))
        if kind == "done":
            return Done(str(rid), JobResult.from_dict(d.get("result") or {}))
        return Failed(None if rid is None else str(rid), str(d.get("message") or "the job failed"),
                      tuple(Diagnostic.from_dict(x) for x in d.get("diagnostics") or ()))
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        return Failed(None if rid is None else str(rid), f"the worker's answer could not be read ({type(exc).__name__}: {exc})")



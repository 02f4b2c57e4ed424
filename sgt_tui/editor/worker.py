"""The editor's worker process: generation and GIF rendering away from the interface.

Run as ``python -m sgt_tui.editor.worker``. It reads one request per line on stdin and answers
with events on stdout, one per line, until stdin closes; both are JSON objects written and read
through the typed classes of :mod:`sgt_tui.editor.protocol` (:class:`~sgt_tui.editor.protocol.JobRequest`
in; :class:`~sgt_tui.editor.protocol.Progress`, then :class:`~sgt_tui.editor.protocol.Done` with a
:class:`~sgt_tui.editor.protocol.JobResult` or :class:`~sgt_tui.editor.protocol.Failed` with the
message and diagnostics, out). It stays alive between requests, so the generator's weights and
the libraries stay loaded ("warm"); cancelling a job kills the process
(:mod:`sgt_tui.editor.jobs` starts a new one for the next job). The script text comes from the
editor (unsaved edits included); file names in it (``@library``, ``@audio``) resolve against
the request's ``path`` folder as usual.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys

from core.motion import save_motion
from model.generate import GenerateError, generate
from model.neural import Options
from renders.animate import render_gif
from renders.clips import concat_clips
from renders.gl import RenderSetupError
from sgt_tui.editor.protocol import Done, Event, Failed, JobRequest, JobResult, Progress, ProtocolError, encode_event

#: Failures whose message is written for the user as it is; any other exception is a bug and
#: its message is prefixed with its type.
USER_ERRORS = (GenerateError, RenderSetupError, ProtocolError, ValueError, OSError)  # NoSuchUtterance is a GenerateError


class _Emitter:
    def __init__(self, stream) -> None:
        self.stream = stream

    def __call__(self, event: Event) -> None:
        self.stream.write(encode_event(event) + "\n")
        self.stream.flush()


def _progress(emit, rid: str, phase: str):
    def cb(done: int, total: int, what: str = "") -> None:
        emit(Progress(rid, phase, int(done), int(total), str(what)[:60]))

    return cb


def _clips(req: dict, emit):
    """Compile the request's text and generate motion; raises GenerateError."""
    rid = req["id"]
    take = generate(req["path"], source=req["source"], engine=req.get("engine"), utterances=req.get("utterances"),
                    seed=req.get("seed"), timing=req.get("timing", "speech"), options=Options(weights=req.get("weights")),
                    progress=_progress(emit, rid, "motion"), speech_progress=_progress(emit, rid, "speech"))
    return take.clips, take.utterances, take.timing, take.engine


def handle(raw: dict, emit) -> JobResult:
    """Run one request (the JSON object as read: ``_clips`` reads it as it is)."""
    req = JobRequest.from_dict(raw)  # raises ProtocolError for an unknown operation
    clips, indices, timing, engine = _clips(raw, emit)
    result = JobResult(utterances=tuple(indices), frames=sum(c.n_frames for c in clips), timing=timing)
    if req.out:
        save_motion(req.out, clips, engine=engine)
        result = dataclasses.replace(result, motion=req.out)
    if req.op == "render":
        info = render_gif(concat_clips(clips), req.gif, size=req.size, progress=_progress(emit, raw["id"], "render"))
        result = dataclasses.replace(result, gif=req.gif, gif_frames=info["frames"])
    return result


def error_event(rid: str | None, exc: BaseException) -> Failed:
    diags = tuple(getattr(exc, "diagnostics", None) or ())
    message = str(exc) or type(exc).__name__
    if not isinstance(exc, USER_ERRORS):
        message = f"{type(exc).__name__}: {message}"
    return Failed(rid, message, diags)


def main() -> int:
    # Keep the protocol stream clean: anything else printed (by C libraries too) goes to stderr.
    out = os.fdopen(os.dup(1), "w", encoding="utf-8", buffering=1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    emit = _Emitter(out)
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            raw = json.loads(line)
        except ValueError:
            emit(Failed(None, "bad request"))
            continue
        rid = str(raw.get("id")) if isinstance(raw, dict) else None
        try:
            result = handle(raw, emit)
        except Exception as exc:  # reported to the editor as a message, never a traceback
            import traceback

            traceback.print_exc(file=sys.stderr)
            emit(error_event(rid, exc))
            continue
        emit(Done(rid, result))
    return 0


if __name__ == "__main__":
    sys.exit(main())

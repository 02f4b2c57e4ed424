"""The editor's worker process: generation and GIF rendering away from the interface.

Run as ``python -m sgt_tui.editor.worker``. It reads one JSON request per line on stdin and
answers with JSON events on stdout, one per line, until stdin closes. It stays alive between
requests, so the generator's weights and the libraries stay loaded ("warm"); cancelling a job
kills the process (:mod:`sgt_tui.editor.jobs` starts a new one for the next job).

Requests::

    {"id": "3", "op": "generate", "path": "lobby.sgt", "source": "<the editor's text>",
     "engine": "rules", "utterances": [2] | null, "seed": null, "timing": "speech",
     "out": "/cache/take.npz"}
    {"id": "4", "op": "render", ...the same..., "gif": "lobby.gif", "size": [320, 320]}
    {"id": "5", "op": "ping"}

Events: ``{"id", "event": "progress", "done", "total", "what", "phase"}``, then one of
``{"id", "event": "done", "result": {...}}`` or ``{"id", "event": "error", "message",
"diagnostics": [...]}``. The script text comes from the editor (unsaved edits included); file
names in it (``@library``, ``@audio``) resolve against ``path``'s folder as usual.
"""

from __future__ import annotations

import json
import os
import sys

from core.motion import save_motion
from model.generate import generate
from model.neural import Options
from renders.animate import render_gif
from renders.clips import concat_clips


class _Emitter:
    def __init__(self, stream) -> None:
        self.stream = stream

    def __call__(self, **event) -> None:
        self.stream.write(json.dumps(event, ensure_ascii=False) + "\n")
        self.stream.flush()


def _progress(emit, rid: str, phase: str):
    def cb(done: int, total: int, what: str = "") -> None:
        emit(id=rid, event="progress", phase=phase, done=int(done), total=int(total), what=str(what)[:60])

    return cb


def _clips(req: dict, emit):
    """Compile the request's text and generate motion; raises GenerateError."""
    rid = req["id"]
    take = generate(req["path"], source=req["source"], engine=req.get("engine"), utterances=req.get("utterances"),
                    seed=req.get("seed"), timing=req.get("timing", "speech"), options=Options(weights=req.get("weights")),
                    progress=_progress(emit, rid, "motion"), speech_progress=_progress(emit, rid, "speech"))
    return take.clips, take.utterances, take.timing


def handle(req: dict, emit) -> dict:
    op = req.get("op")
    if op == "ping":
        return {"pong": True, "pid": os.getpid()}
    if op not in ("generate", "render"):
        raise ValueError(f"unknown request '{op}'")
    clips, indices, timing = _clips(req, emit)
    result = {"utterances": indices, "frames": sum(c.n_frames for c in clips), "timing": timing}
    if req.get("out"):
        save_motion(req["out"], clips)
        result["motion"] = req["out"]
    if op == "render":
        size = tuple(req.get("size") or (320, 320))
        info = render_gif(concat_clips(clips), req["gif"], size=size, progress=_progress(emit, req["id"], "render"))
        result.update(gif=req["gif"], gif_frames=info["frames"], gif_bytes=info["bytes"])
    return result


def _error_event(exc: BaseException) -> dict:
    diags = [d.to_dict() for d in getattr(exc, "diagnostics", []) or []]
    message = str(exc) or exc.__class__.__name__
    if exc.__class__.__name__ not in ("GenerateError", "RenderSetupError", "ValueError", "OSError"):
        message = f"{exc.__class__.__name__}: {message}"
    return {"message": message, "diagnostics": diags}


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
            req = json.loads(line)
        except ValueError:
            emit(id=None, event="error", message="bad request", diagnostics=[])
            continue
        rid = req.get("id")
        try:
            result = handle(req, emit)
        except Exception as exc:  # reported to the editor as a message, never a traceback
            import traceback

            traceback.print_exc(file=sys.stderr)
            emit(id=rid, event="error", **_error_event(exc))
            continue
        emit(id=rid, event="done", result=result)
    return 0


if __name__ == "__main__":
    sys.exit(main())

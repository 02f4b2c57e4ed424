"""The page of ``sgt view`` offered by ``sgt serve`` to its clients (docs/view.md).

``GET /view/`` is the page (and ``/view/static/NAME`` its files: sgt's own, open without the
token, as ``/healthz`` is); in it a client types a script, which ``POST /v1/view`` generates as
``POST /v1/generate`` does (the same body, refusals, allow-list, limits, queue and timeout, and
the token), answering with the page's document (:func:`sgt_tui.view.page.page_take`): the
speech and each speaker's VRM Animation come inside it as ``data:`` URLs.

The page's pose editor works here too (``/v1/pose/...``: :mod:`sgt_tui.view.posing`'s questions,
in the service's queue and with its token), on the service's library; the service writes no
file: the page offers the gesture's TOML to download or copy instead.
"""

from __future__ import annotations

import base64
import json
import tempfile
from pathlib import Path

from fastapi import Request
from fastapi.responses import HTMLResponse, JSONResponse, RedirectResponse, Response

from core.motion import load_motion_file
from renders.audio_mix import mix
from sgt_tui.serve.config import ServeConfig
from sgt_tui.serve.jobs import generate_request
from sgt_tui.serve.requests import GenerateRequest, RequestError
from sgt_tui.view.assets import asset, index_html
from sgt_tui.view.page import data_url, page_take, vrma_bytes, wav_of
from sgt_tui.view.posing import PoseError, frame_answer, gesture_answer, json_body, mirror_answer, preview_answer, refusal, vocabulary

#: Paths under this prefix are the page's own files, served without the token.
PAGE = "/view/"


def is_page(path: str) -> bool:
    return path == PAGE.rstrip("/") or path.startswith(PAGE)


def view_job(config: ServeConfig, req: GenerateRequest, library) -> dict:
    """Generate ``req`` (as ``/v1/generate``, with the speech) and make the page's document."""
    answer = json.loads(generate_request(config, req.model_copy(update={"outputs": ["wav"]}), library))
    with tempfile.TemporaryDirectory(prefix="sgt-view-") as tmp:
        folder = Path(tmp)
        (folder / "take.json").write_text(json.dumps(answer["motion"]), encoding="utf-8")
        motion = load_motion_file(folder / "take.json")
        parts = []
        for i, (clip, wav) in enumerate(zip(motion.clips, answer["outputs"]["wav"])):
            if wav is not None and clip.audio_offset is not None:
                (folder / f"{i}.wav").write_bytes(base64.b64decode(wav["data"]))
                parts.append((folder / f"{i}.wav", clip.start + clip.audio_offset))
        n_frames = motion.tracks[0].n_frames if motion.tracks else sum(c.n_frames for c in motion.clips)
        audio = wav_of(*mix(parts, n_frames)) if parts else None
    doc = page_take(motion, "<request>")
    doc.update(id=None, take=0, audio=None if audio is None else data_url("audio/wav", audio), audio_note="",
               vrma=[data_url("model/gltf-binary", vrma_bytes(motion, s)) for s in range(len(doc["speakers"]))],
               diagnostics=answer["diagnostics"])
    return doc


def add_view(app, config: ServeConfig, work, state: dict) -> None:
    """The page and ``POST /v1/view`` on the service's ``app``; ``work`` runs a job in its pool."""

    @app.get("/view", include_in_schema=False)
    async def view_redirect():
        return RedirectResponse(PAGE)

    @app.get(PAGE, include_in_schema=False)
    async def view_page():
        return HTMLResponse(index_html("service"), headers={"Cache-Control": "no-cache"})

    @app.get(PAGE + "static/{name}", include_in_schema=False)
    async def view_static(name: str):
        found = asset(name)
        if found is None:
            return Response(status_code=404)
        return Response(found[0], media_type=found[1], headers={"Cache-Control": "no-cache"})

    @app.post("/v1/view", summary="A script or a plain text as the page of `sgt view` shows it (docs/view.md)")
    async def view_take(body: GenerateRequest):
        text = body.script or body.text
        if text is not None and len(text) > config.max_text:
            return JSONResponse({"error": f"the script is {len(text)} characters; this service takes at most {config.max_text}"},
                                status_code=413)
        return await work(view_job, config, body, state["library"])

    def refused(work, *args):
        """``work(*args)`` with its :class:`PoseError` as the service's refusal (its status, its line)."""
        try:
            return work(*args)
        except PoseError as exc:
            raise RequestError(exc.status, str(exc)) from None

    @app.get("/v1/pose/info", summary="What the page's pose editor needs: the rest pose, hands, labels, gestures")
    async def pose_info():
        return vocabulary(state["library"].names(), folders=[], script=None, can_write=False, start=None, new_folder=None)

    @app.get("/v1/pose/gesture", summary="A gesture of the library as the pose editor starts from it")
    async def pose_gesture(name: str):
        return await work(refused, gesture_answer, state["library"], name)

    for path, compute in (("frame", frame_answer), ("preview", preview_answer), ("mirror", mirror_answer)):
        app.add_api_route(f"/v1/pose/{path}", _compute_route(work, refused, compute), methods=["POST"],
                          summary=f"The pose editor's {path} (docs/view.md)")


def _compute_route(work, refused, compute):
    async def route(request: Request):
        try:
            body = await json_body(request)
        except PoseError as exc:
            return refusal(exc)
        return await work(refused, compute, body)

    return route

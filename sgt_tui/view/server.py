"""The ASGI application of ``sgt view``: the page, its take, the speech, the reload signal.

| path | answer |
|---|---|
| ``/``, ``/static/NAME`` | the page and its files (never need the token: they are sgt's own) |
| ``/api/status`` | ``{"version", "takes": [{"name", "id", "busy", "error", "details", "note", "warnings"}]}`` |
| ``/api/wait?version=N`` | the status once its version is not N any more (or after :data:`WAIT_S`): the page's reload signal |
| ``/api/take?take=K`` | take K's document (:func:`sgt_tui.view.page.page_take`) with its ``id``, ``audio`` and ``vrma`` URLs |
| ``/api/audio.wav?take=K`` | its speech on the performance clock (404 without speech) |
| ``/api/vrma?take=K&speaker=S`` | speaker S's motion as VRM Animation |

With a token (``--token``, required for a non-loopback ``--host``, as ``sgt serve`` has it),
``/api/`` answers 401 unless the request sends ``Authorization: Bearer TOKEN``; the page takes
the token from its address (``#token=...``, never sent to the server) or asks for it. Every
path, the page's too, answers only requests that name this server as their Host and come from
no other origin (:class:`sgt_tui.serve.origin.SameOrigin`: 421, 403). A take or speaker number
out of range (a negative one too) is a 404.
"""

from __future__ import annotations

import asyncio
import gzip
import json
import logging

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse, Response

from sgt_tui.serve.app import authorized, error
from sgt_tui.serve.config import ServeConfig
from sgt_tui.serve.origin import SameOrigin
from sgt_tui.view.assets import asset, index_html
from sgt_tui.view.takes import Viewer, ViewError

log = logging.getLogger("sgt.view")
#: Seconds a ``/api/wait`` request waits for a change before it answers anyway.
WAIT_S = 20.0


class TokenGuard:
    """ASGI middleware: ``/api/`` needs the token when the viewer has one (401 otherwise)."""

    def __init__(self, app, config: ServeConfig) -> None:
        self.app = app
        self.config = config

    async def __call__(self, scope, receive, send):
        if scope["type"] == "http" and scope["path"].startswith("/api/"):
            headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", ())}
            if not authorized(self.config, headers.get("authorization")):
                return await error(401, "a valid token is required: open the address sgt view printed (#token=...)",
                                   headers={"WWW-Authenticate": "Bearer"})(scope, receive, send)
        return await self.app(scope, receive, send)


def create_view_app(viewer: Viewer, config: ServeConfig) -> FastAPI:
    app = FastAPI(title="sgt view", docs_url=None, redoc_url=None, openapi_url=None)
    app.add_middleware(TokenGuard, config=config)
    app.add_middleware(SameOrigin, config=config)  # added last: the outermost, before the token

    def missing(take: int) -> JSONResponse | None:
        """A 404 for a take number out of range (never Python's indexing from the end)."""
        if 0 <= take < len(viewer.slots):
            return None
        return error(404, f"no take {take}: there {'is 1' if len(viewer.slots) == 1 else f'are {len(viewer.slots)}'}, "
                          f"numbered from 0")

    @app.get("/", response_class=HTMLResponse)
    async def page():
        return HTMLResponse(index_html("file"), headers={"Cache-Control": "no-cache"})

    @app.get("/static/{name}")
    async def static(name: str):
        found = asset(name)
        if found is None:
            return error(404, f"no such file: {name}")
        return Response(found[0], media_type=found[1], headers={"Cache-Control": "no-cache"})

    @app.get("/api/status")
    async def status():
        return viewer.status()

    @app.get("/api/wait")
    async def wait(request: Request, version: int):
        deadline = asyncio.get_running_loop().time() + WAIT_S
        while viewer.version == version and asyncio.get_running_loop().time() < deadline:
            if await request.is_disconnected():  # the page went: nobody to answer
                return Response(status_code=204)
            await asyncio.sleep(0.05)
        return viewer.status()

    @app.get("/api/take")
    def take(request: Request, take: int = 0):  # a thread: loading a take generates a script
        if (refused := missing(take)) is not None:
            return refused
        try:
            loaded, number = viewer.take(take)
        except IndexError:
            return error(404, f"no take {take}: there are {len(viewer.slots)}")
        except ViewError as exc:
            return error(422, str(exc), ({"details": exc.details},) if exc.details else ())
        doc = dict(loaded.doc, id=number, take=take,
                   audio=f"api/audio.wav?take={take}&id={number}" if loaded.audio is not None else None, audio_note=loaded.note,
                   vrma=[f"api/vrma?take={take}&speaker={s}&id={number}" for s in range(len(loaded.doc["speakers"]))])
        body = json.dumps(doc, separators=(",", ":")).encode("utf-8")
        if "gzip" in request.headers.get("accept-encoding", ""):
            return Response(gzip.compress(body, 5), media_type="application/json",
                            headers={"Content-Encoding": "gzip", "Cache-Control": "no-store"})
        return Response(body, media_type="application/json", headers={"Cache-Control": "no-store"})

    @app.get("/api/audio.wav")
    def audio(take: int = 0):
        if (refused := missing(take)) is not None:
            return refused
        try:
            loaded, _ = viewer.take(take)
        except (IndexError, ViewError) as exc:
            return error(404, str(exc) or f"no take {take}")
        if loaded.audio is None:
            return error(404, loaded.note or "this take has no speech")
        return Response(loaded.audio, media_type="audio/wav", headers={"Cache-Control": "no-store"})

    @app.get("/api/vrma")
    def vrma(take: int = 0, speaker: int = 0):
        if (refused := missing(take)) is not None:
            return refused
        try:
            loaded, _ = viewer.take(take)
        except (IndexError, ViewError) as exc:
            return error(404, str(exc) or f"no take {take}")
        if not 0 <= speaker < len(loaded.doc["speakers"]):
            return error(404, f"no speaker {speaker}")
        return Response(loaded.vrma_of(speaker), media_type="model/gltf-binary", headers={"Cache-Control": "no-store"})

    @app.exception_handler(Exception)
    async def unexpected(request: Request, exc: Exception):
        log.error("unexpected error in %s %s", request.method, request.url.path, exc_info=exc)
        return JSONResponse({"error": "internal error; the terminal running sgt view has the details"}, status_code=500)

    return app

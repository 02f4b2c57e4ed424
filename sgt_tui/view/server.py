"""The ASGI application of ``sgt view``: the page, its take, the speech, the reload signal.

| path | answer |
|---|---|
| ``/``, ``/static/NAME`` | the page and its files (never need the token: they are sgt's own) |
| ``/api/status`` | ``{"version", "takes": [{"name", "id", "busy", "error", "details", "note", "warnings"}]}`` |
| ``/api/wait?version=N`` | the status once its version is not N any more (or after :data:`WAIT_S`): the page's reload signal |
| ``/api/take?take=K`` | take K's document (:func:`sgt_tui.view.page.page_take`) with its ``id``, ``audio`` and ``vrma`` URLs |
| ``/api/audio.wav?take=K`` | its speech on the performance clock (404 without speech) |
| ``/api/vrma?take=K&speaker=S`` | speaker S's motion as VRM Animation |
| ``/api/pose/...`` | the pose editor's (:mod:`sgt_tui.view.posing`): its writes need the edit token too |

With a token (``--token``, required for a non-loopback ``--host``, as ``sgt serve`` has it),
``/api/`` answers 401 unless the request sends ``Authorization: Bearer TOKEN``; the page takes
the token from its address (``#token=...``, never sent to the server) or asks for it. Every
path, the page's too, answers only requests that name this server as their Host and come from
no other origin (:class:`sgt_tui.serve.origin.SameOrigin`: 421, 403). A take or speaker number
out of range (a negative one too) is a 404.

Ctrl+c (:class:`ViewServer`) stops it at once and quietly: the long polls and the requests that
wait for a take answer 503 ("sgt view is stopping"), the load under way is cancelled
(:meth:`sgt_tui.view.takes.Viewer.close`), and a connection still sending its answer after
:data:`CUT_S` is cut, so that uvicorn, which cancels what runs 1 s after ctrl+c, has nothing
left to cancel (it would print a traceback per request).
"""

from __future__ import annotations

import asyncio
import contextlib
import gzip
import json
import logging
import threading

import uvicorn
from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse, Response

from sgt_tui.serve.app import authorized, error
from sgt_tui.serve.config import ServeConfig
from sgt_tui.serve.origin import SameOrigin
from sgt_tui.serve.server import Server
from sgt_tui.view.assets import asset, index_html
from sgt_tui.view.posing import Poser, add_view_routes
from sgt_tui.view.takes import STOPPING, Viewer, ViewError

log = logging.getLogger("sgt.view")
#: Seconds a ``/api/wait`` request waits for a change before it answers anyway.
WAIT_S = 20.0
#: Seconds between two looks of a waiting request at its page and at ctrl+c.
LOOK_S = 0.05
#: Requests whose work runs in threads at once (the others wait their turn).
THREADS = 16
#: Seconds after ctrl+c that a connection still sending its answer (to a client that reads
#: slowly) is given before it is cut.
CUT_S = 0.5


class ViewServer(Server):
    """The server (ctrl+c again changes nothing), telling ``viewer`` at ctrl+c (its signal
    handler) that sgt view stops, and cutting, :data:`CUT_S` after, the connections still busy."""

    def __init__(self, config: uvicorn.Config, viewer: Viewer) -> None:
        super().__init__(config)
        self.viewer = viewer

    def handle_exit(self, sig, frame) -> None:
        self.viewer.close()  # takes no lock: it may interrupt any code of the main thread
        super().handle_exit(sig, frame)

    async def shutdown(self, sockets=None) -> None:
        # A stop without ctrl+c. After one, never close again here: a second ctrl+c landing while
        # this holds the event's lock would have its handler wait on it for ever.
        if not self.viewer.closing.is_set():
            self.viewer.close()
        cut = asyncio.get_running_loop().call_later(CUT_S, self._cut)
        try:
            await super().shutdown(sockets=sockets)
        finally:
            cut.cancel()

    def _cut(self) -> None:
        """Close the connections still open: their requests' sends then return at once (uvicorn
        drops what is sent to a closed connection) and the requests end."""
        for connection in list(self.server_state.connections):
            connection.transport.abort()


def stopping() -> JSONResponse:
    return error(503, f"{STOPPING}: start it again")


def _retrieved(task: asyncio.Future) -> None:
    """Take a finished future's exception, so that asyncio does not log it as never retrieved."""
    if not task.cancelled():
        task.exception()


def in_thread(work, *args) -> asyncio.Future:
    """``work(*args)`` in a daemon thread of its own, its outcome as a future of the running loop.
    Not a worker of the loop's pool: Python waits for those when it exits, and the work (reading
    a motion file, generating a script) may run on for seconds after ctrl+c."""
    loop = asyncio.get_running_loop()
    future = loop.create_future()
    future.add_done_callback(_retrieved)

    def settle(outcome, value) -> None:
        if not future.done():
            outcome(value)

    def run() -> None:
        try:
            outcome, value = future.set_result, work(*args)
        except BaseException as exc:  # noqa: BLE001 - raised again in the request (a bug: its 500)
            outcome, value = future.set_exception, exc
        with contextlib.suppress(RuntimeError):  # the loop has closed: sgt view stopped
            loop.call_soon_threadsafe(settle, outcome, value)

    threading.Thread(target=run, name="sgt-view-request", daemon=True).start()
    return future


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


def create_view_app(viewer: Viewer, config: ServeConfig, poser: Poser | None = None) -> FastAPI:
    app = FastAPI(title="sgt view", docs_url=None, redoc_url=None, openapi_url=None)
    app.add_middleware(TokenGuard, config=config)
    app.add_middleware(SameOrigin, config=config)  # added last: the outermost, before the token

    threads = asyncio.Semaphore(THREADS)

    async def unless_stopping(work, *args):
        """``work(*args)`` in a thread (it may load a take: generate a script), its answer; a 503
        once sgt view stops first (the load is cancelled; the thread is not waited for)."""
        async with threads:
            future = in_thread(work, *args)
            while not future.done() and not viewer.closing.is_set():
                await asyncio.wait([future], timeout=LOOK_S)
            return stopping() if viewer.closing.is_set() else future.result()

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
            if viewer.closing.is_set():
                return stopping()
            if await request.is_disconnected():  # the page went: nobody to answer
                return Response(status_code=204)
            await asyncio.sleep(LOOK_S)
        return viewer.status()

    @app.get("/api/take")
    async def take(request: Request, take: int = 0):
        if (refused := missing(take)) is not None:
            return refused
        return await unless_stopping(take_answer, take, "gzip" in request.headers.get("accept-encoding", ""))

    def take_answer(take: int, gzipped: bool):  # in a thread: loading a take generates a script
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
        if gzipped:
            return Response(gzip.compress(body, 5), media_type="application/json",
                            headers={"Content-Encoding": "gzip", "Cache-Control": "no-store"})
        return Response(body, media_type="application/json", headers={"Cache-Control": "no-store"})

    @app.get("/api/audio.wav")
    async def audio(take: int = 0):
        if (refused := missing(take)) is not None:
            return refused
        return await unless_stopping(audio_answer, take)

    def audio_answer(take: int):
        try:
            loaded, _ = viewer.take(take)
        except (IndexError, ViewError) as exc:
            return error(404, str(exc) or f"no take {take}")
        if loaded.audio is None:
            return error(404, loaded.note or "this take has no speech")
        return Response(loaded.audio, media_type="audio/wav", headers={"Cache-Control": "no-store"})

    @app.get("/api/vrma")
    async def vrma(take: int = 0, speaker: int = 0):
        if (refused := missing(take)) is not None:
            return refused
        return await unless_stopping(vrma_answer, take, speaker)

    def vrma_answer(take: int, speaker: int):
        try:
            loaded, _ = viewer.take(take)
        except (IndexError, ViewError) as exc:
            return error(404, str(exc) or f"no take {take}")
        if not 0 <= speaker < len(loaded.doc["speakers"]):
            return error(404, f"no speaker {speaker}")
        return Response(loaded.vrma_of(speaker), media_type="model/gltf-binary", headers={"Cache-Control": "no-store"})

    if poser is not None:
        add_view_routes(app, poser, unless_stopping)

    @app.exception_handler(Exception)
    async def unexpected(request: Request, exc: Exception):
        log.error("unexpected error in %s %s", request.method, request.url.path, exc_info=exc)
        return JSONResponse({"error": "internal error; the terminal running sgt view has the details"}, status_code=500)

    return app

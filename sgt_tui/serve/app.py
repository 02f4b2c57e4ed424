"""The ASGI application of ``sgt serve``: endpoints, errors as JSON, the token and size guard.

Every answer is JSON. A bad request gets a 4xx with ``error`` (one line) and, where they
exist, ``diagnostics`` (the same objects as ``sgt check --format json``); an unexpected failure
is a 500 whose body says only that (the traceback goes to the server's log, never to the
client).
"""

from __future__ import annotations

import asyncio
import hmac
import json
import logging
from contextlib import asynccontextmanager
from contextvars import ContextVar
from functools import partial

from fastapi import Depends, FastAPI, File, Form, Request, UploadFile, WebSocket, WebSocketDisconnect
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from pydantic import ValidationError
from starlette.exceptions import HTTPException
from starlette.requests import HTTPConnection

from library import load_library
from model.runtime import load_runner
from sgt_tui.serve.config import ServeConfig
from sgt_tui.serve.jobs import Encoded, check, generate_request
from sgt_tui.serve.origin import SameOrigin, refuse
from sgt_tui.serve.pool import Busy, ClientGone, Pool
from sgt_tui.serve.requests import AUDIO_SUFFIXES, CheckRequest, GenerateRequest, RequestError
from sgt_tui.serve.stream import StreamSession, StreamSlots
from sgt_tui.view.service import add_view, is_page

log = logging.getLogger("sgt.serve")
OPEN_PATHS = ("/healthz",)  # answered without the token: says only that the service is up
TIMINGS_SUFFIXES = (".json", ".textgrid")
UPLOAD = "/v1/generate/upload"  # the route that takes multipart bodies (sgt_tui.serve.origin)
#: Seconds a client refused a stream (all of them open) is told to wait.
STREAM_RETRY_S = 5


def error(status: int, message: str, diagnostics=(), headers=None) -> JSONResponse:
    body = {"error": message}
    if diagnostics:
        body["diagnostics"] = list(diagnostics)
    return JSONResponse(body, status_code=status, headers=headers)


def authorized(config: ServeConfig, header: str | None) -> bool:
    if config.token is None:
        return True
    scheme, _, value = (header or "").partition(" ")
    return scheme.lower() == "bearer" and hmac.compare_digest(value.strip().encode(), config.token.encode())


#: The request being answered (every route depends on :func:`_remember_request`): ``work``
#: watches its client.
_request: ContextVar[HTTPConnection | None] = ContextVar("sgt_serve_request", default=None)


async def _remember_request(connection: HTTPConnection) -> None:
    _request.set(connection)


async def _disconnect(receive) -> None:
    """Ends when the client disconnects: what the request's ``receive`` says once its body is read."""
    while (await receive())["type"] != "http.disconnect":
        pass


class Guard:
    """ASGI middleware after :class:`sgt_tui.serve.origin.SameOrigin`: the token (401), then the
    body, read whole up to ``max_body`` bytes (413) within ``timeout`` seconds (408), so no
    endpoint sees more."""

    def __init__(self, app, config: ServeConfig) -> None:
        self.app = app
        self.config = config

    async def __call__(self, scope, receive, send):
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", ())}
        if scope["path"] not in OPEN_PATHS and not is_page(scope["path"]) and not authorized(self.config, headers.get("authorization")):
            return await refuse(scope, receive, send, 401, "a valid token is required: send 'Authorization: Bearer TOKEN'",
                                headers={"WWW-Authenticate": "Bearer"})
        if scope["type"] == "websocket":
            return await self.app(scope, receive, send)
        limit = self.config.max_body
        length = headers.get("content-length")
        if length is not None and (not length.isdigit() or int(length) > limit):
            status = 413 if length.isdigit() else 400
            return await error(status, f"the body is larger than this service takes ({limit} bytes)" if status == 413
                               else "bad Content-Length header")(scope, receive, send)
        try:
            body = await asyncio.wait_for(self._read(receive, limit), self.config.timeout)
        except TimeoutError:
            return await error(408, f"the body did not arrive within {self.config.timeout:g} s")(scope, receive, send)
        if body is None:
            return await error(413, f"the body is larger than this service takes ({limit} bytes)")(scope, receive, send)
        replayed = False

        async def replay():
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        return await self.app(scope, replay, send)

    @staticmethod
    async def _read(receive, limit: int) -> bytes | None:
        chunks, total = [], 0
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return b"".join(chunks)
            chunk = message.get("body", b"")
            total += len(chunk)
            if total > limit:
                return None
            chunks.append(chunk)
            if not message.get("more_body"):
                return b"".join(chunks)


def create_app(config: ServeConfig) -> FastAPI:
    """The application for checked settings (:func:`sgt_tui.serve.config.checked`)."""
    state: dict = {}

    @asynccontextmanager
    async def lifespan(_app):
        state["runner"] = load_runner(config.weights)  # warm: the first request does not pay for it
        state["library"] = load_library()
        state["pool"] = Pool(config.workers, config.queue)
        yield
        state["pool"].shutdown()

    app = FastAPI(title="sgt", summary="Co-speech gesture generation for running agents (docs/serve.md)",
                  version="1", lifespan=lifespan, dependencies=[Depends(_remember_request)])
    app.add_middleware(Guard, config=config)
    app.add_middleware(SameOrigin, config=config, uploads=(UPLOAD,))  # added last: the outermost, before the token
    streams = StreamSlots(config.max_streams, config.max_client_streams)

    @app.exception_handler(RequestValidationError)
    async def invalid(_request, exc: RequestValidationError):
        return error(422, "the request does not match the API (docs/serve.md)", _validation(exc.errors()))

    @app.exception_handler(HTTPException)
    async def http_error(_request, exc: HTTPException):
        return error(exc.status_code, str(exc.detail), headers=getattr(exc, "headers", None))

    @app.exception_handler(RequestError)
    async def refused(_request, exc: RequestError):
        return error(exc.status, str(exc), exc.diagnostics)

    @app.exception_handler(Exception)
    async def unexpected(request: Request, exc: Exception):
        log.exception("unexpected error in %s %s", request.method, request.url.path)
        return error(500, "internal error; the server's log has the details")

    async def work(fn, *args):
        """``fn(*args)`` in the pool, answered as JSON; the work is cancelled when the request
        times out (408) or its client disconnects (watched on the request's ASGI ``receive``)."""
        pool: Pool = state["pool"]
        request = _request.get()
        gone = partial(_disconnect, request.receive) if isinstance(request, Request) else None
        try:
            answer = await pool.run(fn, *args, timeout=config.timeout, gone=gone)
            if isinstance(answer, Encoded):
                return Response(answer, media_type="application/json")
            return JSONResponse(answer)
        except Busy as exc:
            return error(503, str(exc), headers={"Retry-After": str(exc.retry_after)})
        except TimeoutError:
            return error(408, f"the request took longer than this service allows ({config.timeout:g} s)")
        except ClientGone:  # nobody reads it: the status is for the access log
            return error(499, "the client went away before the answer was ready")
        except RequestError as exc:
            return error(exc.status, str(exc), exc.diagnostics)

    def too_long(text: str | None) -> JSONResponse | None:
        if text is not None and len(text) > config.max_text:
            return error(413, f"the script is {len(text)} characters; this service takes at most {config.max_text}")
        return None

    @app.get("/healthz", summary="Is the service up")
    async def healthz():
        return {"status": "ok", "runtime": state["runner"].kind, "pool": state["pool"].stats(), "streams": streams.stats()}

    @app.get("/v1/library", summary="The gestures a script can name")
    async def library():
        lib = state["library"]
        return {"gestures": [{"name": g.name, "description": g.description, "tags": g.tags, "duration": g.duration,
                              "origin": g.origin} for g in (lib.get(n) for n in lib.names())]}

    @app.post("/v1/check", summary="Diagnostics of a script, as `sgt check --format json`")
    async def check_script(body: CheckRequest):
        return too_long(body.script) or await work(check, config, body.script, state["library"])

    @app.post("/v1/generate", summary="Motion for a script or a plain text")
    async def generate(body: GenerateRequest):
        return too_long(body.script or body.text) or await work(generate_request, config, body, state["library"])

    @app.post(UPLOAD, summary="Motion for a recording and its transcript (multipart)")
    async def generate_upload(request: str = Form(..., description="GenerateRequest as JSON, with 'text' = the transcript"),
                              audio: UploadFile = File(..., description="the recording: WAV, FLAC or MP3"),
                              timings: UploadFile | None = File(None, description="word timings: JSON or TextGrid")):
        try:
            body = GenerateRequest.model_validate(json.loads(request))
        except json.JSONDecodeError as exc:
            return error(422, f"the 'request' field is not JSON: {exc.msg} at line {exc.lineno} column {exc.colno}")
        except ValidationError as exc:
            return error(422, "the request does not match the API (docs/serve.md)", _validation(exc.errors(), ("request",)))
        if body.text is None:
            return error(422, "an uploaded recording needs its transcript as 'text' (a script names recordings with @audio)")
        upload = {"audio": (_suffix(audio, AUDIO_SUFFIXES, "recording"), await audio.read())}
        if timings is not None:
            upload["timings"] = (_suffix(timings, TIMINGS_SUFFIXES, "timings file"), await timings.read())
        return too_long(body.text) or await work(generate_request, config, body, state["library"], upload)

    @app.websocket("/v1/stream")
    async def stream(socket: WebSocket):
        client = socket.client.host if socket.client else ""
        refusal = streams.take(client)
        if refusal is not None:
            return await refuse(socket.scope, socket.receive, socket.send, 503, refusal,
                                headers={"Retry-After": str(STREAM_RETRY_S)})
        try:
            await run_stream(socket)
        finally:
            streams.give_back(client)

    async def run_stream(socket: WebSocket):
        await socket.accept()
        session = StreamSession(state["runner"], state["library"], config.database)
        pool: Pool = state["pool"]
        try:
            while not session.closed:
                try:
                    text = await asyncio.wait_for(socket.receive_text(), config.stream_idle)
                except TimeoutError:
                    await socket.send_json({"type": "error", "message": f"no message for {config.stream_idle:g} s: closing"})
                    await socket.close(1000)
                    return
                except KeyError:  # a binary frame
                    await socket.send_json({"type": "error", "message": "send JSON text messages"})
                    continue
                try:
                    message = json.loads(text)
                except json.JSONDecodeError as exc:
                    await socket.send_json({"type": "error", "message": f"not JSON: {exc.msg}"})
                    continue
                try:
                    replies = await pool.run(session.handle, message, timeout=config.timeout)
                except Busy as exc:
                    await socket.send_json({"type": "error", "message": str(exc), "retry_after": exc.retry_after})
                    await socket.close(1013)
                    return
                except TimeoutError:
                    await socket.send_json({"type": "error", "message": f"a message took longer than {config.timeout:g} s"})
                    await socket.close(1011)
                    return
                for reply in replies:
                    await socket.send_json(reply)
            await socket.close(1000)
        except WebSocketDisconnect:
            return

    add_view(app, config, work, state)  # the page of `sgt view` at /view/ and POST /v1/view (sgt_tui/view/service.py)
    return app


def _suffix(upload: UploadFile, allowed: tuple[str, ...], what: str) -> str:
    name = (upload.filename or "").lower()
    suffix = next((s for s in allowed if name.endswith(s)), None)
    if suffix is None:
        raise RequestError(415, f"the {what} '{upload.filename}' must end in {', '.join(allowed)}")
    return suffix


def _validation(errors, prefix=()) -> list[dict]:
    """Pydantic's errors as short diagnostics: where in the body, and what is wrong (never the input)."""
    out = []
    for e in errors:
        where = ".".join(str(p) for p in (*prefix, *e.get("loc", ())) if p != "body") or "body"
        out.append({"severity": "error", "where": where, "message": e.get("msg", "invalid")})
    return out

"""``sgt lsp``: the language server, pygls on standard input and output.

Diagnostics are published on open and after every change, from the editor's chunked analysis
(a change re-analyses the utterances it touched; ``python benchmarks/bench_lsp.py`` measures
the time from a change to its diagnostics). Requests are answered from the analysis of the
document's current text (:mod:`sgt_tui.lsp.features`, :mod:`~sgt_tui.lsp.actions`,
:mod:`~sgt_tui.lsp.outline`); the preview command runs in a thread, its work in the editor's
worker process (:mod:`sgt_tui.lsp.preview`); recordings are aligned in a child process
(:mod:`sgt_tui.lsp.aligning`), so that no request waits for the aligner.

Every request gets an answer, as JSON-RPC and the protocol ask, whatever the client sends:
a message that is no JSON, ParseError; params that are not the method's, InvalidParams; a
method the server does not have (with or without params), MethodNotFound; any request before
``initialize``, ServerNotInitialized, and after ``shutdown``, InvalidRequest. Messages are
read with bounded headers and bodies (:data:`MAX_HEADER`, :data:`MAX_MESSAGE`). An error
answer is one line: a failure of the server's own is logged with its traceback on standard
error (the editor's log of the server), never sent to the client.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import re
import sys
from threading import Event

from lsprotocol import types as lsp
from pygls.exceptions import (
    FeatureNotificationError,
    JsonRpcException,
    JsonRpcInternalError,
    JsonRpcInvalidParams,
    JsonRpcInvalidRequest,
    JsonRpcMethodNotFound,
    JsonRpcParseError,
    JsonRpcRequestCancelled,
)
from pygls.io_ import StdoutWriter
from pygls.lsp.server import LanguageServer
from pygls.protocol import LanguageServerProtocol
from pygls.uris import to_fs_path

from core.fileio import LinkRefused, OutputError, OutputExists, resolved_inside
from core.reading import InputFileError, MiB
from dsl.fmt import FormatError
from dsl.parser import read_source
from dsl.speech import SpeechError
from dsl.speech.recording import aligner_timings, check_timings_target, write_timings_file
from sgt_tui import cli
from sgt_tui.lsp import actions, features, outline
from sgt_tui.lsp.aligning import Aligner
from sgt_tui.lsp.documents import Document, Documents, path_of
from sgt_tui.lsp.index import Workspace
from sgt_tui.lsp.preview import PreviewFailed, Previews
from sgt_tui.lsp.timing import SpeechTimes

#: The LSP error code of a request the server understood but could not do (RequestFailed).
REQUEST_FAILED = -32803
#: The LSP error code of a request before ``initialize``.
SERVER_NOT_INITIALIZED = -32002
PREVIEW = "sgt.preview"
#: The longest header line and message body read from the client, bytes (a script may be
#: 32 MiB, escaped in JSON).
MAX_HEADER = 8 * 1024
MAX_MESSAGE = 96 * MiB
#: The longest error message sent to the client, characters.
MAX_ERROR = 400

log = logging.getLogger("sgt.lsp")
_CONTENT_LENGTH = re.compile(rb"content-length[ \t]*:[ \t]*(\d{1,12})[ \t]*\r?\n?", re.IGNORECASE)


def one_line(text: str) -> str:
    """``text`` as one line of at most :data:`MAX_ERROR` characters."""
    line = " ".join(str(text).split())
    return line if len(line) <= MAX_ERROR else line[: MAX_ERROR - 3] + "..."


class _Answered:
    """What a message that was answered while it was read becomes (nothing more to do)."""


class SgtProtocol(LanguageServerProtocol):
    """pygls' protocol, answering every request (see the module's docstring)."""

    def structure_message(self, data):
        if not isinstance(data, dict) or "jsonrpc" not in data:
            return data
        try:
            return super().structure_message(data)
        except JsonRpcException:
            pass  # (pygls logged why on standard error)
        if "method" in data and "id" in data:  # a request: answer it
            method, msg_id = data["method"], _msg_id(data["id"])
            if not isinstance(method, str) or (msg_id is None and data["id"] is not None):
                error = JsonRpcInvalidRequest("a request's method is a string, its id a number or a string")
            elif (refused := self._refusal(method)) is not None:
                error = refused
            elif self.get_message_type(method) is not None or self._has_feature(method):
                error = JsonRpcInvalidParams(f"invalid params for {one_line(method)}")
            else:
                error = JsonRpcMethodNotFound.of(one_line(method))
            self._send_response(msg_id, error=error.to_response_error())
        else:
            log.warning("ignored a malformed message (%s)", one_line(str(data.get("method", "no method"))))
        return _Answered()

    def _has_feature(self, method: str) -> bool:
        return method in self.fm.builtin_features or method in self.fm.features

    def handle_body(self, body: bytes) -> None:
        """One message from the client: parse it and handle it (a ParseError answered)."""
        try:
            data = json.loads(body)
        except (ValueError, RecursionError) as exc:  # not JSON (UnicodeDecodeError is a ValueError)
            log.warning("a message is not JSON: %s", one_line(exc))
            self._send_response(None, error=JsonRpcParseError("the message is not JSON").to_response_error())
            return
        message = self.structure_message(data)  # (the message itself only: what it holds is its params)
        if isinstance(message, _Answered):
            return
        if not hasattr(message, "jsonrpc"):  # JSON, but no JSON-RPC message
            answer = isinstance(message, dict) and "id" in message
            log.warning("ignored a message that is not JSON-RPC 2.0")
            if answer:
                self._send_response(_msg_id(message["id"]),
                                    error=JsonRpcInvalidRequest("not a JSON-RPC 2.0 message").to_response_error())
            return
        self.handle_message(message)

    def _refusal(self, method: str) -> JsonRpcException | None:
        """Why a message of ``method`` is not handled now: after ``shutdown`` (only ``exit``
        is), before ``initialize``; None when it is."""
        if method == lsp.EXIT:
            return None
        if self._shutdown:
            return JsonRpcInvalidRequest(f"the server is shut down: it takes only 'exit', not {one_line(method)}")
        if self._workspace is None and method != lsp.INITIALIZE:
            return JsonRpcException(f"the server is not initialized: {one_line(method)} before 'initialize'",
                                    code=SERVER_NOT_INITIALIZED)
        return None

    def handle_message(self, message) -> None:
        method = getattr(message, "method", None)
        if message.jsonrpc == self.VERSION and isinstance(method, str):
            refused = self._refusal(method)
            if refused is not None:
                if hasattr(message, "id"):  # a request: answered; a notification: dropped
                    self._send_response(message.id, error=refused.to_response_error())
                return
        super().handle_message(message)

    def _send_handler_result(self, future, *, msg_id):
        """Send a request's result or error: one line, never a traceback (that is logged)."""
        self._request_futures.pop(msg_id, None)
        if future.cancelled():
            self._send_response(msg_id, error=JsonRpcRequestCancelled(f"request {msg_id} was cancelled").to_response_error())
            return
        exc = future.exception()
        if exc is None:
            self._send_response(msg_id, result=future.result())
            return
        if isinstance(exc, JsonRpcException):
            error = JsonRpcException(one_line(exc.message), code=exc.code)
        else:
            log.error("a request failed", exc_info=(type(exc), exc, exc.__traceback__))
            error = JsonRpcInternalError(one_line(f"internal error: {type(exc).__name__}: {exc} "
                                                  "(the server's log has the details)"))
        self._send_response(msg_id, error=error.to_response_error())


def _msg_id(value):
    """A request's id as JSON-RPC allows it (a number or a string), else None."""
    return value if isinstance(value, (int, str)) and not isinstance(value, bool) else None


class SgtServer(LanguageServer):
    def __init__(self) -> None:
        super().__init__("sgt", cli._version(), protocol_cls=SgtProtocol)  # the installed version, as `sgt --version` says
        self.aligner = Aligner(self._aligned_soon)
        self.docs = Documents(self.aligner)
        self.index = Workspace()
        self.timing = SpeechTimes()
        self.previews = Previews(self.timing)
        self._pending: set[str] = set()
        self._published: dict[str, set[str]] = {}  # a script's URI -> the URIs its diagnostics went to
        self._shown: dict[str, bool] = {}  # a script's URI -> whether the client shows diagnostics of it
        self._loop: asyncio.AbstractEventLoop | None = None

    # -- the connection ------------------------------------------------------------------------
    def start_io(self, stdin=None, stdout=None) -> None:
        """Serve on standard input and output (bounded reads; see the module's docstring)."""
        self._stop_event = Event()
        self.protocol.set_writer(StdoutWriter(stdout or sys.stdout.buffer))
        try:
            asyncio.run(self._serve(stdin or sys.stdin.buffer))
        except BrokenPipeError:
            log.error("the connection to the client is lost: the server stops")
        except (KeyboardInterrupt, SystemExit):
            pass
        finally:
            self.aligner.close()
            self.shutdown()

    async def _serve(self, stdin) -> None:
        loop = self._loop = asyncio.get_running_loop()

        async def read(fn, *args):
            return await loop.run_in_executor(self.thread_pool, fn, *args)

        while not self._stop_event.is_set():
            length, header = None, False
            while True:  # the header lines, up to an empty one
                line = await read(stdin.readline, MAX_HEADER)
                if not line:
                    return  # the client closed the connection
                if not line.endswith(b"\n"):  # a header line too long: skipped
                    while not line.endswith(b"\n"):
                        line = await read(stdin.readline, MAX_HEADER)
                        if not line:
                            return
                    header = True
                    continue
                if not line.strip():
                    if header:
                        break
                    continue
                header = True
                m = _CONTENT_LENGTH.fullmatch(line)
                if m:
                    length = int(m.group(1))
            if length is None:
                log.warning("ignored a message without Content-Length")
                continue
            if length > MAX_MESSAGE:
                log.warning("ignored a message of %d bytes (at most %d are read)", length, MAX_MESSAGE)
                self.window_show_message(lsp.ShowMessageParams(lsp.MessageType.Error, one_line(
                    f"sgt lsp: a message of {length / MiB:.0f} MiB was ignored (at most {MAX_MESSAGE // MiB} MiB)")))
                while length > 0:
                    skipped = await read(stdin.read, min(length, MiB))
                    if not skipped:
                        return
                    length -= len(skipped)
                continue
            body = await read(stdin.read, length)
            if len(body) < length:
                return
            try:
                self.protocol.handle_body(body)
            except (SystemExit, KeyboardInterrupt):
                raise
            except Exception:  # pygls' own failure: logged, the server goes on
                log.exception("a message could not be handled")

    def report_server_error(self, error: Exception, source) -> None:
        """pygls' errors outside a request: the traceback to standard error only; a failing
        notification handler is also told to the user, in one line."""
        log.error("%s", one_line(error), exc_info=(type(error), error, error.__traceback__)
                  if error.__traceback__ is not None else None)
        if source is FeatureNotificationError:
            self.window_show_message(lsp.ShowMessageParams(lsp.MessageType.Error, one_line(
                f"sgt lsp: {error} (the server's log has the details)")))

    # -- diagnostics ---------------------------------------------------------------------------
    def changed(self, uri: str) -> None:
        """Publish the diagnostics of ``uri`` soon: changes that arrive together are analysed once."""
        if not self._pending:
            asyncio.get_running_loop().call_soon(self._publish_pending)
        self._pending.add(uri)

    def _aligned_soon(self, uris: list[str]) -> None:
        """(The aligner's thread.) Recordings these scripts waited for are done."""
        loop = self._loop
        if loop is not None and not loop.is_closed():
            loop.call_soon_threadsafe(self._aligned, uris)

    def _aligned(self, uris: list[str]) -> None:
        for uri in uris:
            if self.docs.get(uri) is not None:
                self.changed(uri)

    def _publish_pending(self) -> None:
        pending, self._pending = self._pending, set()
        for uri in pending:
            doc = self.docs.get(uri)
            if doc is not None:
                self.publish(doc)

    def publish(self, doc: Document) -> None:
        """Publish the diagnostics of ``doc``. While recordings of it are aligning, they are
        published without theirs only when there is something to show or to clear; theirs
        follow when the aligner is done."""
        by_uri = actions.published(doc)
        shown = any(by_uri.values())
        if doc.aligning and not shown and not self._shown.get(doc.uri):
            return
        self._shown[doc.uri] = shown
        for gone in self._published.get(doc.uri, set()) - set(by_uri):
            self.text_document_publish_diagnostics(lsp.PublishDiagnosticsParams(gone, []))
        self._published[doc.uri] = set(by_uri)
        for uri, diags in by_uri.items():
            self.text_document_publish_diagnostics(
                lsp.PublishDiagnosticsParams(uri, diags, version=doc.version if uri == doc.uri else None))

    def close(self, uri: str) -> None:
        """Forget a closed document and clear the diagnostics it published."""
        self.docs.close(uri)
        self._shown.pop(uri, None)
        for target in self._published.pop(uri, {uri}):
            self.text_document_publish_diagnostics(lsp.PublishDiagnosticsParams(target, []))

    def doc(self, uri: str) -> Document:
        """The open document ``uri``, or the script file it names under the workspace's folders
        (read by the bounded reader, links resolved); RequestFailed for anything else."""
        doc = self.docs.get(uri)
        if doc is not None:
            return doc
        path = self.index.inside(path_of(uri)) if uri.startswith("file:") else None
        if path is None:
            raise _failed(f"{one_line(uri)} is not open, nor a file under the workspace's folders")
        try:
            text, _ = read_source(path)
        except InputFileError as exc:
            raise _failed(f"{path}: {exc.reason}") from None
        except OSError as exc:
            raise _failed(f"{path}: {(exc.strerror or str(exc)).lower()}") from None
        return self.docs.unopened(uri, text)


def _failed(message: str) -> JsonRpcException:
    return JsonRpcException(message, code=REQUEST_FAILED)


server = SgtServer()


@server.feature(lsp.INITIALIZE)
def initialize(ls: SgtServer, params: lsp.InitializeParams) -> None:
    ls.docs.encoding = ls.workspace.position_encoding or lsp.PositionEncodingKind.Utf16
    roots = [to_fs_path(f.uri) for f in params.workspace_folders or ()]
    if not roots and params.root_uri:
        roots = [to_fs_path(params.root_uri)]
    if not roots and params.root_path:
        roots = [params.root_path]
    ls.index.set_roots(roots)


@server.feature(lsp.SHUTDOWN)
def shutdown(ls: SgtServer, params) -> None:
    ls.aligner.close()
    ls.previews.shutdown()


@server.feature(lsp.TEXT_DOCUMENT_DID_OPEN)
def did_open(ls: SgtServer, params: lsp.DidOpenTextDocumentParams) -> None:
    item = params.text_document
    ls.docs.open(item.uri, item.text, item.version)
    ls.changed(item.uri)


@server.feature(lsp.TEXT_DOCUMENT_DID_CHANGE)
def did_change(ls: SgtServer, params: lsp.DidChangeTextDocumentParams) -> None:
    uri = params.text_document.uri
    text = ls.workspace.get_text_document(uri).source  # pygls has applied the changes
    doc = ls.docs.get(uri)
    if doc is None:
        ls.docs.open(uri, text, params.text_document.version)
    else:
        doc.set_text(text, params.text_document.version)
    ls.changed(uri)


@server.feature(lsp.TEXT_DOCUMENT_DID_CLOSE)
def did_close(ls: SgtServer, params: lsp.DidCloseTextDocumentParams) -> None:
    ls.close(params.text_document.uri)


@server.feature(lsp.TEXT_DOCUMENT_COMPLETION,
                lsp.CompletionOptions(trigger_characters=[":", "[", "<", "@", "+", "/", "="], resolve_provider=True))
def completion(ls: SgtServer, params: lsp.CompletionParams) -> lsp.CompletionList:
    doc = ls.doc(params.text_document.uri)
    row, col = doc.char_at(params.position)
    return lsp.CompletionList(is_incomplete=False, items=features.complete(doc, row, col, ls.index))


@server.feature(lsp.COMPLETION_ITEM_RESOLVE)
def completion_resolve(ls: SgtServer, item: lsp.CompletionItem) -> lsp.CompletionItem:
    data = item.data if isinstance(item.data, dict) else {}
    uri, gesture = data.get("uri"), data.get("gesture")
    doc = ls.docs.get(uri) if isinstance(uri, str) else None
    return features.resolve_gesture(doc, item) if doc is not None and isinstance(gesture, str) else item


@server.feature(lsp.TEXT_DOCUMENT_HOVER)
def hover(ls: SgtServer, params: lsp.HoverParams) -> lsp.Hover | None:
    doc = ls.doc(params.text_document.uri)
    return features.hover(doc, *doc.char_at(params.position), ls.timing)


@server.feature(lsp.TEXT_DOCUMENT_DEFINITION)
def definition(ls: SgtServer, params: lsp.DefinitionParams) -> list[lsp.Location]:
    doc = ls.doc(params.text_document.uri)
    return features.definition(doc, *doc.char_at(params.position))


@server.feature(lsp.TEXT_DOCUMENT_REFERENCES)
def references(ls: SgtServer, params: lsp.ReferenceParams) -> list[lsp.Location]:
    doc = ls.doc(params.text_document.uri)
    return features.references(doc, *doc.char_at(params.position), ls.docs, ls.index, params.context.include_declaration)


@server.feature(lsp.TEXT_DOCUMENT_PREPARE_RENAME)
def prepare_rename(ls: SgtServer, params: lsp.PrepareRenameParams) -> lsp.Range:
    doc = ls.doc(params.text_document.uri)
    try:
        return features.prepare_rename(doc, *doc.char_at(params.position))
    except features.RenameRefused as exc:
        raise _failed(str(exc)) from None


@server.feature(lsp.TEXT_DOCUMENT_RENAME)
def rename(ls: SgtServer, params: lsp.RenameParams) -> lsp.WorkspaceEdit:
    doc = ls.doc(params.text_document.uri)
    caps = ls.client_capabilities.workspace
    operations = (caps.workspace_edit.resource_operations or []) if caps and caps.workspace_edit else []
    try:
        return features.rename(doc, *doc.char_at(params.position), params.new_name, ls.docs, ls.index,
                               lsp.ResourceOperationKind.Rename in operations)
    except features.RenameRefused as exc:
        raise _failed(str(exc)) from None


@server.feature(lsp.TEXT_DOCUMENT_CODE_ACTION, lsp.CodeActionOptions(code_action_kinds=[lsp.CodeActionKind.QuickFix]))
def code_action(ls: SgtServer, params: lsp.CodeActionParams) -> list[lsp.CodeAction]:
    return actions.code_actions(ls.doc(params.text_document.uri), params.range)


@server.feature(lsp.TEXT_DOCUMENT_FORMATTING)
def formatting(ls: SgtServer, params: lsp.DocumentFormattingParams) -> list[lsp.TextEdit] | None:
    doc = ls.doc(params.text_document.uri)
    try:
        return actions.formatting(doc)
    except FormatError as exc:
        first = exc.diagnostics[0]
        ls.window_show_message(lsp.ShowMessageParams(
            lsp.MessageType.Warning, f"sgt fmt: not formatted, fix the syntax errors first "
                                     f"(line {first.line}: {first.message})"))
        return None


@server.feature(lsp.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
def document_symbol(ls: SgtServer, params: lsp.DocumentSymbolParams) -> list[lsp.DocumentSymbol]:
    return outline.symbols(ls.doc(params.text_document.uri))


@server.feature(lsp.TEXT_DOCUMENT_FOLDING_RANGE)
def folding_range(ls: SgtServer, params: lsp.FoldingRangeParams) -> list[lsp.FoldingRange]:
    return outline.folding(ls.doc(params.text_document.uri))


@server.feature(lsp.TEXT_DOCUMENT_SEMANTIC_TOKENS_FULL, outline.LEGEND)
def semantic_tokens(ls: SgtServer, params: lsp.SemanticTokensParams) -> lsp.SemanticTokens:
    return outline.semantic_tokens(ls.doc(params.text_document.uri))


@server.feature(lsp.TEXT_DOCUMENT_INLAY_HINT)
def inlay_hint(ls: SgtServer, params: lsp.InlayHintParams) -> list[lsp.InlayHint]:
    return outline.inlay_hints(ls.doc(params.text_document.uri), params.range, ls.timing)


@server.command(PREVIEW)
@server.thread()
def preview(ls: SgtServer, *args) -> dict:
    """``sgt.preview``: arguments ``[uri, line]`` (0-based line) or ``[{"uri", "line",
    "engine"?}]``; answers ``{"gif": path, "utterance": n, "frames", "engine"}``."""
    spec = args[0] if len(args) == 1 and isinstance(args[0], dict) else {"uri": args[0], "line": args[1]} if len(args) >= 2 else {}
    if not isinstance(spec.get("uri"), str) or not isinstance(spec.get("line"), int):
        raise _failed("sgt.preview takes a document URI and a 0-based line")
    try:
        return ls.previews.render(ls.doc(spec["uri"]), spec["line"], engine=spec.get("engine"))
    except PreviewFailed as exc:
        raise _failed(str(exc)) from None


@server.command(actions.WRITE_TIMINGS)
async def write_timings(ls: SgtServer, *args) -> dict:
    """``sgt.writeTimings``: arguments ``[uri, line]`` (1-based line of an utterance spoken from
    a recording without ``timings=``). Writes the times the aligner finds (``sgt align``'s file,
    created only where nothing is, never through a link, and only inside a workspace folder or
    the script's folder), then asks the client to name the file on the ``@audio`` directive;
    answers ``{"path", "rejection"}`` (the check's reason, or None)."""
    if len(args) != 2 or not isinstance(args[0], str) or not isinstance(args[1], int):
        raise _failed("sgt.writeTimings takes a document URI and a 1-based line")
    doc = ls.doc(args[0])
    await _aligned(doc)  # a recording still aligning is left out of the analysis: its utterance would not be found
    found = actions.aligner_times(doc, args[1])
    if found is None:
        raise _failed(f"line {args[1]} is not an utterance spoken from a recording without timings=")
    u, target, edit = found
    script = to_fs_path(doc.uri) if doc.uri.startswith("file:") else None
    folders = [str(r) for r in ls.index.roots] + ([os.path.dirname(script)] if script else [])
    if not any(_inside(folder, target.parent) for folder in folders):
        raise _failed(f"{target} is outside the workspace and the script's folder: not written "
                      f"(sgt align -o DIR writes it where you choose)")
    try:
        check_timings_target(target)
    except OutputError as exc:
        raise _failed(str(exc)) from None
    if os.path.lexists(target):
        raise _failed(f"{target} exists: name it with timings= (it is not replaced)")
    try:
        rejection = await asyncio.to_thread(_write_aligner_times, u, target)
    except OutputExists:
        raise _failed(f"{target} exists: name it with timings= (it is not replaced)") from None
    except (SpeechError, OSError) as exc:
        raise _failed(f"{target}: {getattr(exc, 'message', None) or exc}") from None
    await ls.workspace_apply_edit_async(lsp.ApplyWorkspaceEditParams(
        lsp.WorkspaceEdit(changes={doc.uri: [edit]}), label=f"time the words by {target.name}"))
    return {"path": str(target), "rejection": rejection}


#: The longest sgt.writeTimings waits for the document's recordings to finish aligning, seconds.
ALIGN_WAIT_S = 600.0


async def _aligned(doc: Document) -> None:
    """Wait (without holding up other requests) until no recording of ``doc`` is aligning;
    RequestFailed after :data:`ALIGN_WAIT_S`."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + ALIGN_WAIT_S
    while (doc.analysis(), doc.aligning)[1]:
        if loop.time() > deadline:
            raise _failed(f"the recordings of {doc.path.name} are still being aligned after {ALIGN_WAIT_S:g} s: try again later")
        await asyncio.sleep(0.1)


def _inside(folder: str, path) -> bool:
    try:
        resolved_inside(folder, path)
    except LinkRefused:
        return False
    return True


def _write_aligner_times(u, target) -> str | None:
    """Align ``u``'s recording and write its words' times to ``target`` (as ``sgt align``,
    never over a file: :class:`core.fileio.OutputExists`)."""
    text, _, rejection = aligner_timings(u.audio.path, u.text, u.word_spans)
    write_timings_file(target, text)
    return rejection


def serve() -> None:
    server.start_io()

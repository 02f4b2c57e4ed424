"""``sgt lsp``: the language server, pygls on standard input and output.

Diagnostics are published on open and after every change, from the editor's chunked analysis
(a change re-analyses the utterances it touched; ``python benchmarks/bench_lsp.py`` measures
the time from a change to its diagnostics). Requests are answered from the analysis of the
document's current text (:mod:`sgt_tui.lsp.features`, :mod:`~sgt_tui.lsp.actions`,
:mod:`~sgt_tui.lsp.outline`); the preview command runs in a thread, its work in the editor's
worker process (:mod:`sgt_tui.lsp.preview`).
"""

from __future__ import annotations

import asyncio
import os

from lsprotocol import types as lsp
from pygls.exceptions import JsonRpcException
from pygls.lsp.server import LanguageServer
from pygls.uris import to_fs_path

from core.fileio import LinkRefused, OutputError, OutputExists, resolved_inside
from dsl.fmt import FormatError
from dsl.speech import SpeechError
from dsl.speech.recording import aligner_timings, check_timings_target, write_timings_file
from sgt_tui import cli
from sgt_tui.lsp import actions, features, outline
from sgt_tui.lsp.documents import Document, Documents
from sgt_tui.lsp.index import Workspace
from sgt_tui.lsp.preview import PreviewFailed, Previews
from sgt_tui.lsp.timing import SpeechTimes

#: The LSP error code of a request the server understood but could not do (RequestFailed).
REQUEST_FAILED = -32803
PREVIEW = "sgt.preview"


class SgtServer(LanguageServer):
    def __init__(self) -> None:
        super().__init__("sgt", cli._version())  # the installed version, as `sgt --version` says
        self.docs = Documents()
        self.index = Workspace()
        self.timing = SpeechTimes()
        self.previews = Previews(self.timing)
        self._pending: set[str] = set()
        self._published: dict[str, set[str]] = {}  # a script's URI -> the URIs its diagnostics went to

    # -- diagnostics ---------------------------------------------------------------------------
    def changed(self, uri: str) -> None:
        """Publish the diagnostics of ``uri`` soon: changes that arrive together are analysed once."""
        if not self._pending:
            asyncio.get_running_loop().call_soon(self._publish_pending)
        self._pending.add(uri)

    def _publish_pending(self) -> None:
        pending, self._pending = self._pending, set()
        for uri in pending:
            doc = self.docs.get(uri)
            if doc is not None:
                self.publish(doc)

    def publish(self, doc: Document) -> None:
        by_uri = actions.published(doc)
        for gone in self._published.get(doc.uri, set()) - set(by_uri):
            self.text_document_publish_diagnostics(lsp.PublishDiagnosticsParams(gone, []))
        self._published[doc.uri] = set(by_uri)
        for uri, diags in by_uri.items():
            self.text_document_publish_diagnostics(
                lsp.PublishDiagnosticsParams(uri, diags, version=doc.version if uri == doc.uri else None))

    def close(self, uri: str) -> None:
        """Forget a closed document and clear the diagnostics it published."""
        self.docs.close(uri)
        for target in self._published.pop(uri, {uri}):
            self.text_document_publish_diagnostics(lsp.PublishDiagnosticsParams(target, []))

    def doc(self, uri: str) -> Document:
        doc = self.docs.get(uri)
        if doc is None:  # a request for a document the client did not open: read it from its file
            doc = self.docs.open(uri, self.workspace.get_text_document(uri).source, None)
        return doc


def _failed(message: str) -> JsonRpcException:
    return JsonRpcException(message, code=REQUEST_FAILED)


server = SgtServer()


@server.feature(lsp.INITIALIZE)
def initialize(ls: SgtServer, params: lsp.InitializeParams) -> None:
    ls.docs.encoding = ls.workspace.position_encoding or lsp.PositionEncodingKind.Utf16
    roots = [to_fs_path(f.uri) for f in params.workspace_folders or ()]
    if not roots and params.root_uri:
        roots = [to_fs_path(params.root_uri)]
    ls.index.set_roots(roots)


@server.feature(lsp.SHUTDOWN)
def shutdown(ls: SgtServer, params) -> None:
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
    doc = ls.docs.get(data.get("uri", ""))
    return features.resolve_gesture(doc, item) if doc is not None and "gesture" in data else item


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

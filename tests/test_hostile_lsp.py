"""`sgt lsp` against a hostile client and a hostile workspace, at the raw JSON-RPC level.

Each test runs the real server (`python -m sgt_tui.cli lsp`) and writes Content-Length framed
messages to its standard input, as any client (or anything pretending to be one) can, reading
the answers with timeouts: a request naming a FIFO or /proc/self/fd/0, a workspace with a
script linked to /dev/zero or out of it, a workspace folder of `file:///`, 20,000 equal lines
to format, malformed and unknown requests, requests after shutdown, a script with a 50 s
recording to align, and renames that would merge or shadow names. Every request must get an
answer, in one line, with no Python traceback in anything sent to the client.
"""

from __future__ import annotations

import json
import os
import queue
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from dsl.fmt import format_source
from library import BUILTIN_DIR

ROOT = Path(__file__).resolve().parent.parent
#: The JSON-RPC and LSP error codes the server answers with.
PARSE_ERROR, INVALID_REQUEST, METHOD_NOT_FOUND, INVALID_PARAMS = -32700, -32600, -32601, -32602
NOT_INITIALIZED, REQUEST_FAILED = -32002, -32803
#: Seconds a request may take before the test calls it unanswered (generous: the machine is shared).
ANSWER = 20.0


class RawClient:
    """The server as a subprocess, spoken to in framed JSON-RPC messages."""

    def __init__(self, tmp_path: Path, env: dict | None = None) -> None:
        self.log_path = tmp_path / f"server{id(self)}.log"
        with open(self.log_path, "wb") as log:  # the server's standard error
            self.proc = subprocess.Popen([sys.executable, "-m", "sgt_tui.cli", "lsp"], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, stderr=log, cwd=tmp_path,
                                         env={**os.environ, **(env or {})})
        self.raw = bytearray()  # everything the server wrote
        self.messages: queue.Queue = queue.Queue()
        self.notifications: list[dict] = []
        self._ids = iter(range(1, 1 << 30))
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        out = self.proc.stdout
        while True:
            length = None
            while True:
                line = out.readline()
                if not line:
                    self.messages.put(None)
                    return
                self.raw += line
                if line.strip() == b"":
                    break
                if line.lower().startswith(b"content-length:"):
                    length = int(line.split(b":")[1])
            body = out.read(length)
            self.raw += body
            self.messages.put(json.loads(body))

    def send(self, message: dict | bytes) -> None:
        body = message if isinstance(message, bytes) else json.dumps(message).encode("utf-8")
        self.proc.stdin.write(b"Content-Length: %d\r\n\r\n" % len(body) + body)
        self.proc.stdin.flush()

    def notify(self, method: str, params=None) -> None:
        self.send({"jsonrpc": "2.0", "method": method, **({"params": params} if params is not None else {})})

    def request(self, method: str, params=None, *, timeout: float = ANSWER, raw: dict | None = None) -> dict:
        """Send a request (``raw``: the message as it is) and wait for its answer (the whole
        response message); notifications that come meanwhile are kept."""
        msg_id = next(self._ids) if raw is None else raw.get("id")
        self.send(raw if raw is not None else {"jsonrpc": "2.0", "id": msg_id, "method": method,
                                              **({"params": params} if params is not None else {})})
        return self.answer(msg_id, timeout)

    def answer(self, msg_id, timeout: float = ANSWER) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            try:
                message = self.messages.get(timeout=max(left, 0.01))
            except queue.Empty:
                raise AssertionError(f"no answer to request {msg_id} within {timeout} s") from None
            if message is None:
                raise AssertionError(f"the server ended before answering {msg_id}: {self.log()[-2000:]}")
            if "method" in message and "id" in message:  # a request of the server's: answer it
                self.send({"jsonrpc": "2.0", "id": message["id"], "result": None})
            elif "method" in message:
                self.notifications.append(message)
            elif message.get("id") == msg_id:
                return message
            if left <= 0:
                raise AssertionError(f"no answer to request {msg_id} within {timeout} s")

    def initialize(self, root: Path | str | None) -> dict:
        uri = root if isinstance(root, str) or root is None else root.as_uri()
        caps = {"workspace": {"workspaceEdit": {"resourceOperations": ["create", "rename", "delete"]}}}
        answer = self.request("initialize", {"processId": None, "rootUri": uri, "capabilities": caps,
                                             "workspaceFolders": [{"uri": uri, "name": "ws"}] if uri else None})
        assert "result" in answer, answer
        self.notify("initialized", {})
        return answer

    def open(self, path: Path, text: str, version: int = 1) -> str:
        uri = path.as_uri()
        self.notify("textDocument/didOpen", {"textDocument": {"uri": uri, "languageId": "sgt", "version": version, "text": text}})
        return uri

    def at(self, uri: str, line: int, character: int) -> dict:
        return {"textDocument": {"uri": uri}, "position": {"line": line, "character": character}}

    def peak_rss_mib(self) -> float:
        """The server's peak resident memory so far (VmHWM), MiB."""
        for line in Path(f"/proc/{self.proc.pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
        raise AssertionError("no VmHWM")

    def children(self) -> list[int]:
        found = []
        for status in Path("/proc").glob("[0-9]*/status"):
            try:
                fields = dict(line.split(":\t", 1) for line in status.read_text().splitlines() if ":\t" in line)
            except OSError:
                continue
            if fields.get("PPid", "").strip() == str(self.proc.pid):
                found.append(int(status.parent.name))
        return found

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def close(self) -> None:
        """Shut down and exit (the exit status checked); no traceback was sent to the client."""
        if self.proc.poll() is None:
            try:
                self.request("shutdown", timeout=10)
                self.notify("exit")
                self.proc.wait(10)
            except (AssertionError, OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()
        assert b"Traceback" not in self.raw, self.raw.decode(errors="replace")[-3000:]


@pytest.fixture
def client(tmp_path):
    clients = []

    def start(env: dict | None = None) -> RawClient:
        c = RawClient(tmp_path, {"SGT_CACHE_DIR": str(tmp_path / "cache"), **(env or {})})
        clients.append(c)
        return c

    yield start
    for c in clients:
        c.close()


def _error(answer: dict, code: int) -> str:
    assert "error" in answer, answer
    error = answer["error"]
    assert error["code"] == code, answer
    assert "\n" not in error["message"] and "Traceback" not in json.dumps(error) and not error.get("data"), answer
    return error["message"]


# -- files the server reads ---------------------------------------------------------------------

def test_a_fifo_or_proc_self_fd_0_named_by_a_request_is_refused_at_once(client, tmp_path):
    ws = tmp_path / "ws"
    ws.mkdir()
    os.mkfifo(ws / "pipe.sgt")
    os.mkfifo(tmp_path / "outside.sgt")
    c = client()
    c.initialize(ws)
    for uri in [(ws / "pipe.sgt").as_uri(), "file:///proc/self/fd/0", (tmp_path / "outside.sgt").as_uri(),
                "file:///dev/zero"]:
        for method in ("textDocument/hover", "textDocument/completion", "textDocument/formatting"):
            params = c.at(uri, 0, 0) if method != "textDocument/formatting" else {
                "textDocument": {"uri": uri}, "options": {"tabSize": 4, "insertSpaces": True}}
            message = _error(c.request(method, params, timeout=10), REQUEST_FAILED)
            assert "FIFO" in message or "not open, nor a file under the workspace" in message, message
    # still serving
    uri = c.open(ws / "ok.sgt", "guide: hello\n")
    assert "result" in c.request("textDocument/hover", c.at(uri, 0, 8))


def test_a_workspace_script_linked_to_dev_zero_or_out_of_the_workspace_is_skipped(client, tmp_path):
    ws = tmp_path / "ws"
    (ws / "scenes").mkdir(parents=True)
    (ws / "zero.sgt").symlink_to("/dev/zero")
    (tmp_path / "secret").mkdir()
    (tmp_path / "secret" / "hidden.sgt").write_text("outsider: I live outside the workspace.\n")
    (ws / "scenes" / "linked.sgt").symlink_to(tmp_path / "secret" / "hidden.sgt")
    (ws / "away").symlink_to(tmp_path / "secret", target_is_directory=True)  # a folder link: not followed
    (ws / "scenes" / "real.sgt").write_text("merchant: Apples!\nguide: Hello.\n")
    c = client()
    c.initialize(ws)
    text = "guide: hello.\nguide: again.\n\n"
    uri = c.open(ws / "main.sgt", text)
    labels = [i["label"] for i in c.request("textDocument/completion", c.at(uri, 2, 0))["result"]["items"]]
    assert "merchant:" in labels and "outsider:" not in labels, labels
    refs = c.request("textDocument/references", {**c.at(uri, 0, 1), "context": {"includeDeclaration": True}})["result"]
    assert {r["uri"] for r in refs} == {uri, (ws / "scenes" / "real.sgt").as_uri()}, refs
    assert c.peak_rss_mib() < 1024
    # a request naming the linked scripts: refused, not read
    _error(c.request("textDocument/hover", c.at((ws / "zero.sgt").as_uri(), 0, 0)), REQUEST_FAILED)
    _error(c.request("textDocument/hover", c.at((ws / "scenes" / "linked.sgt").as_uri(), 0, 0)), REQUEST_FAILED)
    # a script of the workspace the client did not open is read (bounded) and answered from
    hover = c.request("textDocument/hover", c.at((ws / "scenes" / "real.sgt").as_uri(), 0, 2))["result"]
    assert "merchant" in hover["contents"]["value"]


def test_a_workspace_folder_of_the_whole_disk_is_not_crawled(client, tmp_path):
    (tmp_path / "far.sgt").write_text("faraway: somewhere on the disk.\n")
    c = client()
    c.initialize("file:///")
    uri = c.open(tmp_path / "main.sgt", "guide: hello.\n\n")
    started = time.monotonic()
    labels = [i["label"] for i in c.request("textDocument/completion", c.at(uri, 1, 0))["result"]["items"]]
    assert time.monotonic() - started < 5 and "faraway:" not in labels, labels
    assert "the file system's root" in c.log()


def test_the_workspace_scan_is_bounded_by_names_and_folders_not_only_scripts(tmp_path, monkeypatch):
    from sgt_tui.lsp import index  # the scan's bounds, made small here

    ws = tmp_path / "ws"
    for n in range(40):
        (ws / f"a{n:02d}").mkdir(parents=True)
        for k in range(5):
            (ws / f"a{n:02d}" / f"f{k}.txt").write_text("")
    (ws / "zz").mkdir()
    (ws / "zz" / "late.sgt").write_text("late: found.\n")
    w = index.Workspace()
    w.set_roots([ws])
    assert w.scripts() == [ws / "zz" / "late.sgt"]
    monkeypatch.setattr(index, "MAX_ENTRIES", 100)
    w.set_roots([ws])
    assert w.scripts() == []  # cut after 100 names, though no script was found
    monkeypatch.setattr(index, "MAX_ENTRIES", 10_000)
    monkeypatch.setattr(index, "MAX_FOLDERS", 10)
    w.set_roots([ws])
    assert w.scripts() == []


# -- formatting ---------------------------------------------------------------------------------

def test_formatting_20000_equal_lines_is_answered(client, tmp_path):
    c = client()
    c.initialize(tmp_path)
    for text in ("guide: hi\n" * 20_000, "guide: hi\nguide:  hi\n" * 10_000):
        uri = c.open(tmp_path / f"t{len(text)}.sgt", text)
        answer = c.request("textDocument/formatting", {"textDocument": {"uri": uri},
                                                       "options": {"tabSize": 4, "insertSpaces": True}}, timeout=60)
        edits = answer["result"] or []
        lines = text.split("\n")
        for e in sorted(edits, key=lambda e: e["range"]["start"]["line"], reverse=True):
            start, end = e["range"]["start"]["line"], e["range"]["end"]["line"]
            lines[start:end] = e["newText"].split("\n")[:-1]
        assert "\n".join(lines) == format_source(text)


# -- the protocol -------------------------------------------------------------------------------

def test_every_request_gets_an_answer_without_a_traceback(client, tmp_path):
    c = client()
    # before initialize
    _error(c.request("textDocument/hover", c.at((tmp_path / "a.sgt").as_uri(), 0, 0)), NOT_INITIALIZED)
    c.initialize(tmp_path)
    uri = c.open(tmp_path / "a.sgt", "guide: hello\n")
    # invalid params
    assert "textDocument/hover" in _error(c.request("textDocument/hover", {}), INVALID_PARAMS)
    _error(c.request("textDocument/hover", {"textDocument": {"uri": uri}, "position": {"line": -1, "character": 0}}),
           INVALID_PARAMS)
    _error(c.request("textDocument/rename", c.at(uri, 0, 1)), INVALID_PARAMS)  # no newName
    _error(c.request("textDocument/hover", [1, 2]), INVALID_PARAMS)
    # unknown methods, with and without params
    assert "sgt/unknown" in _error(c.request("sgt/unknown"), METHOD_NOT_FOUND)
    _error(c.request("sgt/unknown", {"a": 1}), METHOD_NOT_FOUND)
    _error(c.request("", None, raw={"jsonrpc": "2.0", "id": 77, "method": "$/weird"}), METHOD_NOT_FOUND)
    # a request that is no JSON-RPC request, and a message that is no JSON
    _error(c.request("", raw={"jsonrpc": "2.0", "id": 78, "method": 5}), INVALID_REQUEST)
    c.send(b"{not json")
    _error(c.answer(None), PARSE_ERROR)
    c.proc.stdin.write(b"X-Junk: " + b"x" * 1_000_000 + b"\r\n\r\n")  # a header line of a megabyte: skipped
    c.proc.stdin.flush()
    # a command with wrong arguments
    _error(c.request("workspace/executeCommand", {"command": "sgt.preview", "arguments": [1, 2, 3]}), REQUEST_FAILED)
    # nothing broke: a real request is answered
    assert "result" in c.request("textDocument/hover", c.at(uri, 0, 8))
    # after shutdown: InvalidRequest for any request, then exit ends the server with status 0
    assert c.request("shutdown")["result"] is None
    for method, params in (("textDocument/hover", c.at(uri, 0, 8)), ("sgt/unknown", None), ("shutdown", None)):
        assert "shut down" in _error(c.request(method, params), INVALID_REQUEST)
    c.notify("exit")
    assert c.proc.wait(10) == 0
    shown = [n for n in c.notifications if n["method"] in ("window/showMessage", "window/logMessage")]
    assert all("Traceback" not in json.dumps(n) and "\n" not in n["params"]["message"] for n in shown), shown


def test_a_failure_of_the_server_is_answered_in_one_line_and_its_traceback_only_logged(caplog):
    """The server's own bug, in any handler: the answer is one line with no traceback (pygls
    sends the traceback as the error's data), the traceback goes to the server's log."""
    from sgt_tui.lsp.server import SgtServer  # the server's protocol, with a handler that fails

    server = SgtServer()

    @server.feature("textDocument/hover")
    def hover(ls, params):
        raise ValueError("a bug\non two lines")

    @server.feature("textDocument/didSave")
    def saved(ls, params):
        raise ValueError("a bug\non two lines")

    written: list[bytes] = []

    class Writer:
        def write(self, data: bytes) -> None:
            written.append(data)

    server.protocol.set_writer(Writer())
    frame = {"processId": None, "rootUri": None, "capabilities": {}}
    server.protocol.handle_body(json.dumps({"jsonrpc": "2.0", "id": 1, "method": "initialize", "params": frame}).encode())
    server.protocol.handle_body(json.dumps({"jsonrpc": "2.0", "id": 2, "method": "textDocument/hover", "params": {
        "textDocument": {"uri": "file:///x.sgt"}, "position": {"line": 0, "character": 0}}}).encode())
    answer = json.loads(written[-1].split(b"\r\n\r\n", 1)[1])
    assert answer["id"] == 2 and answer["error"]["code"] == -32603
    assert answer["error"]["message"] == "internal error: ValueError: a bug on two lines (the server's log has the details)"
    assert "data" not in answer["error"] or not answer["error"]["data"]
    assert any(r.exc_info and "a bug" in str(r.exc_info[1]) for r in caplog.records)
    # in a notification's handler: the user is told, in one line
    server.protocol.handle_body(json.dumps({"jsonrpc": "2.0", "method": "textDocument/didSave", "params": {
        "textDocument": {"uri": "file:///x.sgt"}}}).encode())
    shown = json.loads(written[-1].split(b"\r\n\r\n", 1)[1])
    assert shown["method"] == "window/showMessage" and "a bug on two lines" in shown["params"]["message"]
    assert "\n" not in shown["params"]["message"]


# -- a long recording ---------------------------------------------------------------------------

def test_requests_are_answered_while_a_long_recording_aligns(client, tmp_path):
    """A script with a 47 s recording and no timings file: the aligner takes about a minute;
    hover, completion and formatting keep answering within a second meanwhile, and closing the
    script stops the alignment."""
    from dsl.speech import _espeak, synthesize  # lazy: espeak-ng, only this test speaks
    from tests.recordings import TTS_SENTENCES

    if _espeak.find_library() is None or shutil.which("espeak-ng") is None:
        pytest.skip("espeak-ng not installed")
    said = " ".join(TTS_SENTENCES)
    spans, at = [], 0
    for word in said.split():
        start = said.index(word, at)
        core = word.strip(",.?!")
        spans.append((start, start + len(core)))
        at = start + len(word)
    speech = synthesize(said, spans, rate=140, cache_dir=tmp_path / "syn")
    assert speech.duration > 40
    shutil.copy(speech.audio_path, tmp_path / "long.wav")
    text = f"@audio long.wav\nguide: [pose:wave] {said}\n\nguide: Thanks.\n"
    c = client()
    c.initialize(tmp_path)
    uri = c.open(tmp_path / "long.sgt", text)
    deadline = time.monotonic() + 30
    while not c.children() and time.monotonic() < deadline:
        time.sleep(0.2)
    assert c.children(), "the alignment did not start"
    slowest = 0.0
    for _ in range(6):
        for method, params in (("textDocument/hover", c.at(uri, 1, 14)), ("textDocument/completion", c.at(uri, 1, 10)),
                               ("textDocument/formatting", {"textDocument": {"uri": uri},
                                                            "options": {"tabSize": 4, "insertSpaces": True}})):
            started = time.monotonic()
            answer = c.request(method, params)
            slowest = max(slowest, time.monotonic() - started)
            assert "result" in answer, answer
        time.sleep(0.5)
    assert slowest < 1.0, slowest
    assert c.children(), "the alignment ended too soon to show anything"
    hover = c.request("textDocument/hover", c.at(uri, 1, 14))["result"]
    assert "**wave**" in hover["contents"]["value"]
    c.notify("textDocument/didClose", {"textDocument": {"uri": uri}})  # nobody needs it: the aligner stops
    deadline = time.monotonic() + 5
    while c.children() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not c.children()


# -- renames ------------------------------------------------------------------------------------

def test_renames_that_would_merge_shadow_or_break_names_are_refused(client, tmp_path):
    (tmp_path / "mine").mkdir()
    spec = (BUILTIN_DIR / "wave.toml").read_text(encoding="utf-8")
    for name in ("my_wave", "my_nod"):
        (tmp_path / "mine" / f"{name}.toml").write_text(spec.replace('name = "wave"', f'name = "{name}"', 1), encoding="utf-8")
    text = ("@library ./mine\n@preset shy = space:-2\n@preset bold = space:2\n"
            "guide: [pose:my_wave] Hello <shy>there</shy>. [look:visitor] Look.\nvisitor: Hi [pose:my_nod] guide.\n")
    c = client()
    c.initialize(tmp_path)
    uri = c.open(tmp_path / "main.sgt", text)

    def rename(line: int, character: int, new_name: str) -> dict:
        return c.request("textDocument/rename", {**c.at(uri, line, character), "newName": new_name})

    refused = {
        (3, 1, "visitor"): "would merge the two speakers",
        (3, 1, "Visitor"): "would merge the two speakers",
        (3, 1, "left"): "direction",
        (3, 1, "two words"): "not a speaker name",
        (3, 1, "x" * 300): "too long",
        (3, 1, "x" * 100_000): "too long",
        (3, 15, "wave"): "built-in gesture",
        (3, 15, "my_nod"): "a gesture of yours",
        (3, 15, "y" * 300): "too long",
        (3, 30, "bold"): "would merge the two presets",
        (3, 30, "z" * 100_000): "too long",
    }
    for (line, character, new_name), why in refused.items():
        message = _error(rename(line, character, new_name), REQUEST_FAILED)
        assert why in message and len(message) < 400, (new_name[:20], message)
    # a good rename still works, [look:...] included
    edit = rename(4, 1, "tourist")["result"]
    assert sorted((e["range"]["start"]["line"], e["newText"]) for e in edit["changes"][uri]) == [(3, "tourist"), (4, "tourist")]

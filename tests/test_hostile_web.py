"""Web pages cannot use `sgt serve` or `sgt view`: the real servers, each in its own process on
127.0.0.1, against curl, the `websockets` client and headless Chromium.

- DNS rebinding: a request that names another server as its Host (a page's own name resolved to
  127.0.0.1: curl --resolve, a WebSocket opened on a socket to 127.0.0.1, Chromium's
  *.localhost) is refused with 421 on every route of both servers, pages and files too, and its
  answer holds nothing of the script;
- another origin (Origin, Sec-Fetch-Site) is refused with 403, a WebSocket too (it never
  streams); a form's body (a cross-origin multipart upload, text/plain or urlencoded JSON) is
  refused before any work (the pool's counts in /healthz do not move);
- what is allowed still works: loopback names, the server's own origin, no Origin, a name given
  with --allow-host (http and https origins), a link followed from another site, the page in
  Chromium (its take under sgt view; generating under sgt serve);
- streams are capped (in all and per client address) and, with 1000 WebSockets or 1000 idle
  connections coming at a service run with `ulimit -n 256`, /healthz still answers and no
  descriptor runs out;
- `sgt view`'s take and speaker numbers out of range (negative ones too) are 404s, and a long
  poll whose page went away ends.
"""

from __future__ import annotations

import contextlib
import json
import re
import resource
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from dsl.speech.audio import wav_bytes
from sgt_tui.serve.app import create_app
from sgt_tui.serve.config import ServeConfig, checked
from sgt_tui.view.server import create_view_app
from sgt_tui.view.takes import Viewer

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
SCRIPT = "@seed 2\nguide: Look at the marmalade [pose:point_right] on the shelf over there.\n"
WORD = "marmalade"  # in every answer that holds the take, and in none of the refusals
PROXY = "proxy.example.test"
EVIL = "attacker.example"


class Served:
    """`sgt COMMAND ARGS --port 0` in its own process, its log in a file; ``url``, ``port``."""

    def __init__(self, folder: Path, *args: str, nofile: int | None = None) -> None:
        self.log = folder / f"{args[0]}-{time.monotonic_ns()}.log"
        command = [sys.executable, "-m", "sgt_tui", *args, "--port", "0"]
        if nofile:  # as `ulimit -n` in a shell (exec: the server is the process started)
            command = ["sh", "-c", f'ulimit -n {nofile} && exec "$0" "$@"', *command]
        with open(self.log, "w") as log:
            self.proc = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=log)
        deadline = time.monotonic() + 120
        while (m := re.search(r"^sgt \w+: (http://127\.0\.0\.1:(\d+))", self.log.read_text(), re.MULTILINE)) is None:
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.stop()
                pytest.fail(f"sgt {args[0]} did not start: {self.log.read_text()[-2000:]}")
            time.sleep(0.1)
        self.url, self.port = m.group(1), int(m.group(2))
        if args[0] == "serve":
            while health(self) is None:
                time.sleep(0.2)

    def descriptors(self) -> int:
        return len(list(Path(f"/proc/{self.proc.pid}/fd").iterdir()))

    def stop(self) -> tuple[int, str]:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode, self.log.read_text()


def health(server: Served) -> dict | None:
    try:
        with urllib.request.urlopen(server.url + "/healthz", timeout=10) as r:
            return json.load(r)
    except OSError:
        return None


def curl(*args: str) -> tuple[int, str]:
    """(status, body) of a curl call (HTTP/1.1, 30 s at most)."""
    r = subprocess.run(["curl", "-s", "--http1.1", "--max-time", "30", "-w", "\n%{http_code}", *args],
                       check=False, capture_output=True, text=True, timeout=60)
    body, _, status = r.stdout.rpartition("\n")
    return int(status), body


def refused(status: int, body: str, expected: int) -> str:
    """The one-line error of a refusal with ``expected``, checked to hold nothing of the take."""
    assert status == expected, (status, body[:300])
    error = json.loads(body)["error"]
    assert "\n" not in error and WORD not in body
    return error


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("hostile")
    (folder / "talk.sgt").write_text(SCRIPT)
    wav = wav_bytes(np.sin(np.arange(20000) / 7.0) * 0.3, 16000)
    (folder / "hello.wav").write_bytes(wav)
    return folder


@pytest.fixture(scope="module")
def serve(folder):
    server = Served(folder, "serve", "--allow-host", PROXY)
    yield server
    code, log = server.stop()
    assert code == 0 and "Traceback" not in log, log[-2000:]


@pytest.fixture(scope="module")
def view(folder):
    server = Served(folder, "view", str(folder / "talk.sgt"))
    yield server
    code, log = server.stop()
    assert code == 0 and "Traceback" not in log, log[-2000:]


def routes(app, **values) -> list[tuple[str, str]]:
    """(method, path) of every route of ``app`` (WS for a WebSocket), path parameters filled in."""
    out = []
    for route in app.routes:
        path = re.sub(r"\{(\w+)\}", lambda m: values[m.group(1)], route.path)
        for method in sorted(getattr(route, "methods", None) or {"WS"}):
            if method != "HEAD":
                out.append((method, path))
    return out


def serve_routes() -> list[tuple[str, str]]:
    return routes(create_app(checked(ServeConfig())), name="viewer.js")


def view_routes(folder: Path) -> list[tuple[str, str]]:
    return routes(create_view_app(Viewer(folder / "talk.sgt"), checked(ServeConfig())), name="viewer.js")


def ask(server: Served, method: str, path: str, *args: str, host: str | None = None) -> tuple[int, str]:
    """curl ``method path`` on ``server`` (a WebSocket handshake for WS), reaching it by ``host``
    (a name curl resolves to 127.0.0.1, as a rebinding DNS answer does) when given."""
    name = host or "127.0.0.1"
    where = ["--resolve", f"{host}:{server.port}:127.0.0.1"] if host else []
    if method == "WS":
        args = ("-H", "Connection: Upgrade", "-H", "Upgrade: websocket", "-H", "Sec-WebSocket-Version: 13",
                "-H", "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==", *args)
    elif method == "POST":
        args = ("-H", "Content-Type: application/json", "-d", '{"text": "Hello there", "script": "guide: Hello there."}', *args)
    return curl(*where, "-X", "GET" if method == "WS" else method, *args, f"http://{name}:{server.port}{path}")


# -- DNS rebinding: another Host ------------------------------------------------------------------------------------------


def test_a_rebinding_host_is_refused_on_every_route_of_sgt_serve(serve):
    before = health(serve)["pool"]
    for method, path in serve_routes():
        for host in (EVIL, "localhost.attacker.example", "127.0.0.1.nip.io"):
            status, body = ask(serve, method, path, host=host)
            refused(status, body, 421)
        status, body = ask(serve, method, path, "-H", f"Host: 127.0.0.1:{serve.port + 1}")  # another port: another server
        refused(status, body, 421)
    assert health(serve)["pool"] == before  # nothing was admitted to work
    with pytest.raises(InvalidStatus) as e:  # the websockets client, on a socket to 127.0.0.1 with the page's name
        connect(f"ws://{EVIL}:{serve.port}/v1/stream", sock=socket.create_connection(("127.0.0.1", serve.port)), open_timeout=10)
    assert e.value.response.status_code == 421


def test_a_rebinding_host_is_refused_on_every_route_of_sgt_view(view, folder):
    status, body = ask(view, "GET", "/api/take?take=0")
    assert status == 200 and WORD in body  # the take holds the word the refusals must not
    for method, path in view_routes(folder):
        for query in ("", "?take=0", "?version=-1"):
            status, body = ask(view, method, path + query, host=EVIL)
            refused(status, body, 421)
    status, body = ask(view, "GET", "/api/take?take=0", "-H", "Host: attacker.example")
    refused(status, body, 421)


# -- another origin --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("origin", ["http://evil.example", "null", "http://localhost:1", "https://127.0.0.1:{port}",
                                    "http://127.0.0.1:{port}.evil.example", "http://127.0.0.1:{port}/path"])
def test_another_origin_is_refused_get_post_and_websocket(serve, view, origin):
    before = health(serve)["pool"]
    for server, paths in ((serve, [("GET", "/v1/library"), ("GET", "/view/"), ("POST", "/v1/generate"), ("POST", "/v1/check"),
                                   ("POST", "/v1/view"), ("WS", "/v1/stream")]),
                          (view, [("GET", "/"), ("GET", "/api/take?take=0"), ("GET", "/api/audio.wav"), ("GET", "/api/status")])):
        for method, path in paths:
            status, body = ask(server, method, path, "-H", "Origin: " + origin.format(port=server.port))
            refused(status, body, 403)
    assert health(serve)["pool"] == before
    stream = f"ws://127.0.0.1:{serve.port}/v1/stream"
    with pytest.raises(InvalidStatus) as e, connect(stream, origin=origin.format(port=serve.port), open_timeout=10) as ws:
        ws.send(json.dumps({"type": "start"}))  # a page's WebSocket is refused before it is accepted: it never streams
        pytest.fail(f"the stream opened for {origin}: {ws.recv(timeout=10)}")
    assert e.value.response.status_code == 403 and "origin" in json.loads(e.value.response.body)["error"]
    assert health(serve)["streams"]["open"] == 0


def test_another_site_is_refused_but_a_link_to_a_page_is_followed(serve, view):
    for site in ("cross-site", "same-site"):  # same-site: another port of this machine
        for server, path in ((serve, "/v1/library"), (serve, "/healthz"), (view, "/api/take?take=0"), (view, "/static/viewer.js")):
            status, body = ask(server, "GET", path, "-H", f"Sec-Fetch-Site: {site}", "-H", "Sec-Fetch-Mode: no-cors",
                               "-H", "Sec-Fetch-Dest: script")
            refused(status, body, 403)
    link = ("-H", "Sec-Fetch-Site: cross-site", "-H", "Sec-Fetch-Mode: navigate", "-H", "Sec-Fetch-Dest: document")
    assert ask(view, "GET", "/", *link)[0] == 200
    assert ask(serve, "GET", "/view/", *link)[0] == 200
    status, body = ask(view, "GET", "/", *link[:4], "-H", "Sec-Fetch-Dest: iframe")  # framed by another site: no
    refused(status, body, 403)


def test_a_cross_origin_form_upload_does_no_work(serve, folder):
    request = {"text": "hello there", "words": [{"word": "hello", "start": 0.1, "end": 0.5}, {"word": "there", "start": 0.6, "end": 1.0}]}
    form = ("-F", f"request={json.dumps(request)}", "-F", f"audio=@{folder / 'hello.wav'}")
    before = health(serve)["pool"]
    browser = ("-H", "Origin: http://evil.example", "-H", "Sec-Fetch-Site: cross-site", "-H", "Sec-Fetch-Mode: navigate")
    upload = serve.url + "/v1/generate/upload"
    refused(*curl(*browser, *form, upload), 403)
    error = refused(*curl(*form, upload), 403)  # a browser that sent no Origin: still a form
    assert "X-Requested-With" in error
    assert health(serve)["pool"] == before  # no work was done
    status, body = curl("-H", "X-Requested-With: sgt", *form, upload)  # a program's upload
    assert status == 200 and json.loads(body)["motion"]["utterances"][0]["words"][0]["word"] == "hello"
    assert health(serve)["pool"]["completed"] == before["completed"] + 1  # the pool counts a job it did
    status, body = curl("-H", f"Origin: {serve.url}", "-H", "Sec-Fetch-Site: same-origin", *form, upload)  # from /docs
    assert status == 200 and health(serve)["pool"]["completed"] == before["completed"] + 2


@pytest.mark.parametrize("kind", ["text/plain", "text/plain; charset=utf-8", "application/x-www-form-urlencoded",
                                  "multipart/form-data; boundary=x"])
def test_a_form_body_on_a_json_route_is_refused(serve, kind):
    before = health(serve)["pool"]
    for path in ("/v1/generate", "/v1/check", "/v1/view"):
        status, body = curl("-H", f"Content-Type: {kind}", "-d", '{"text": "Hello there", "timing": "estimate"}',
                            serve.url + path)
        assert "application/json" in refused(status, body, 415)
    assert health(serve)["pool"] == before


# -- what is allowed --------------------------------------------------------------------------------------------------------


def test_this_servers_names_and_origin_and_an_allowed_proxy_still_work(serve, view):
    for host in ("localhost", "127.0.0.1", "127.8.9.10", "[::1]"):
        assert ask(serve, "GET", "/v1/library", "-H", f"Host: {host}:{serve.port}")[0] == 200
        status, body = ask(view, "GET", "/api/take?take=0", "-H", f"Host: {host}:{view.port}")
        assert status == 200 and WORD in body
    check = ("-H", "Content-Type: application/json", "-d", '{"script": "guide: Hello [pose:wavee] there."}')
    for origin in (f"http://127.0.0.1:{serve.port}", f"http://localhost:{serve.port}", f"https://{PROXY}",
                   f"http://{PROXY}", f"http://{PROXY}:8080"):
        status, body = curl(*check, "-H", f"Origin: {origin}", "-H", "Sec-Fetch-Site: same-origin", serve.url + "/v1/check")
        assert status == 200 and json.loads(body)["diagnostics"][0]["code"] == "SGT201", (origin, body)
    assert ask(view, "GET", "/api/take?take=0", "-H", f"Origin: http://localhost:{view.port}")[0] == 200
    assert ask(serve, "GET", "/v1/library", host=PROXY)[0] == 200  # --allow-host: the proxy's name, any port
    assert ask(serve, "GET", "/v1/library", "-H", f"Host: {PROXY}")[0] == 200
    assert ask(view, "GET", "/", host=PROXY)[0] == 421  # not given to sgt view
    for origin, host in ((None, "127.0.0.1"), (f"http://127.0.0.1:{serve.port}", "127.0.0.1"), (f"https://{PROXY}", PROXY)):
        with connect(f"ws://{host}:{serve.port}/v1/stream", origin=origin, open_timeout=10,
                     sock=socket.create_connection(("127.0.0.1", serve.port))) as ws:
            ws.send(json.dumps({"type": "start"}))
            assert json.loads(ws.recv(timeout=30))["type"] == "ready"


def sgt(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sgt_tui", *args], check=False, capture_output=True, text=True, timeout=60)


def test_the_allow_host_option_is_checked_and_in_the_help():
    r = sgt("serve", "--allow-host", "not a name!")
    assert r.returncode == 2 and "--allow-host not a name!: not a host name" in r.stderr
    for command in ("serve", "view"):
        assert "--allow-host NAME[:PORT]" in sgt(command, "--help").stdout
    helped = sgt("serve", "--help").stdout
    assert "421" in helped and "--max-streams N" in helped and "--max-client-streams N" in helped


# -- sgt view: numbers out of range -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("query", ["/api/take?take=-1", "/api/take?take=1", "/api/take?take=-100000000000000000000",
                                   "/api/audio.wav?take=-1", "/api/vrma?take=-1", "/api/vrma?take=0&speaker=-1",
                                   "/api/vrma?take=0&speaker=1", "/api/audio.wav?take=99999999999999999999"])
def test_a_take_or_speaker_out_of_range_is_a_404(view, query):
    status, body = curl(view.url + query)
    assert status == 404 and json.loads(body)["error"] and WORD not in body
    assert len(body) < 200  # never the last take's words, speech or motion


def test_a_long_poll_whose_page_went_away_ends(folder):
    """/api/wait holds its answer up to 20 s; a page that went (a tab closed, the page left)
    ends it at once, so ctrl+c stops sgt view cleanly (uvicorn cancels what still runs after
    1 s, with a traceback)."""
    server = Served(folder, "view", str(folder / "talk.sgt"))
    version = json.loads(curl(server.url + "/api/status")[1])["version"]
    with socket.create_connection(("127.0.0.1", server.port)) as s:
        s.sendall(f"GET /api/wait?version={version} HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\n\r\n".encode())
        time.sleep(0.3)
    time.sleep(0.5)
    started = time.monotonic()
    code, log = server.stop()
    assert code == 0 and "Traceback" not in log and time.monotonic() - started < 5, log[-2000:]


# -- the caps ---------------------------------------------------------------------------------------------------------------


def test_streams_are_capped_and_healthz_answers_through_1000_sockets_at_ulimit_256(folder):
    """1000 WebSockets (from 1000 loopback addresses), then 1000 idle connections, at a service
    whose descriptor limit is 256: at most 32 streams (8 from one address) open; the rest are
    refused with 503 at once; /healthz answers; the service never runs out of descriptors."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft < 4096:  # this process holds the 1000 sockets
        resource.setrlimit(resource.RLIMIT_NOFILE, (4096 if hard == resource.RLIM_INFINITY else min(4096, hard), hard))
    server = Served(folder, "serve", "--header-timeout", "60", nofile=256)
    stream = f"ws://127.0.0.1:{server.port}/v1/stream"
    with contextlib.ExitStack() as held:
        for _ in range(8):
            held.enter_context(connect(stream, open_timeout=10))
        with pytest.raises(InvalidStatus) as e:
            connect(stream, open_timeout=10)
        assert e.value.response.status_code == 503 and "--max-client-streams" in json.loads(e.value.response.body)["error"]
    held = []
    with contextlib.ExitStack() as stack:
        started, turned_away = time.monotonic(), 0
        for k in range(1000):
            try:
                held.append(stack.enter_context(connect(stream, open_timeout=10,
                                                        source_address=(f"127.0.{k // 250}.{2 + k % 250}", 0))))
            except InvalidStatus as refusal:
                assert refusal.response.status_code == 503 and refusal.response.headers["Retry-After"]
                turned_away += 1
            assert time.monotonic() - started < 120
        assert len(held) == 32 and turned_away == 968
        answer = health(server)
        assert answer["status"] == "ok" and answer["streams"]["open"] == 32
        assert server.descriptors() < 128
        with pytest.raises(InvalidStatus) as e:  # one more, from an address with none open
            connect(stream, open_timeout=10)
        assert e.value.response.status_code == 503 and "--max-streams" in json.loads(e.value.response.body)["error"]
        held[0].send(json.dumps({"type": "start"}))  # the streams open still stream
        assert json.loads(held[0].recv(timeout=30))["type"] == "ready"
    deadline = time.monotonic() + 10
    while health(server)["streams"]["open"] and time.monotonic() < deadline:
        time.sleep(0.1)
    assert health(server)["streams"]["open"] == 0  # each closed stream gave its place back
    idle = []
    try:
        for _ in range(1000):
            idle.append(socket.create_connection(("127.0.0.1", server.port), timeout=10))
        started = time.monotonic()
        assert health(server)["status"] == "ok" and time.monotonic() - started < 5
        assert server.descriptors() < 256 - 32
    finally:
        for s in idle:
            s.close()
    code, log = server.stop()
    assert code == 0 and "Too many open files" not in log and "Traceback" not in log, log[-2000:]



def test_requests_behind_a_flood_of_idle_connections_are_answered(folder):
    """2000 connections queued while the service is stopped (SIGSTOP), every 20th a /healthz
    request, the rest idle, at a descriptor limit of 256: once it runs again every request is
    answered 200; none is refused for want of a descriptor or closed as idle."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft < 4096:
        resource.setrlimit(resource.RLIMIT_NOFILE, (4096 if hard == resource.RLIM_INFINITY else min(4096, hard), hard))
    server = Served(folder, "serve", "--header-timeout", "60", nofile=256)
    request = b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nConnection: close\r\n\r\n" % server.port
    answers: dict[str, int] = {}
    with contextlib.ExitStack() as stack:
        server.proc.send_signal(signal.SIGSTOP)
        try:
            queued = []
            for k in range(2000):
                sock = stack.enter_context(socket.create_connection(("127.0.0.1", server.port), timeout=30))
                if k % 20 == 19:
                    sock.sendall(request)
                    queued.append(sock)
        finally:
            server.proc.send_signal(signal.SIGCONT)
        for sock in queued:
            try:
                answer = sock.recv(64).split(b"\r\n")[0].decode() or "closed"
            except OSError as exc:
                answer = type(exc).__name__
            answers[answer] = answers.get(answer, 0) + 1
    assert answers == {"HTTP/1.1 200 OK": 100}
    code, log = server.stop()
    assert code == 0 and "Traceback" not in log, log[-2000:]



@pytest.mark.parametrize("again_after", [0.0, 0.02, 0.05])
def test_ctrl_c_twice_stops_the_service_quietly(folder, again_after):
    """A second ctrl+c while the first stop is under way changes nothing: no traceback (uvicorn's
    forced exit cancelled the application's lifespan task as the loop closed, and it was logged)."""
    server = Served(folder, "serve")
    server.proc.send_signal(signal.SIGINT)
    time.sleep(again_after)
    server.proc.send_signal(signal.SIGINT)
    server.proc.wait(30)
    log = server.log.read_text()
    # 0; or death by the second SIGINT after the last line of Python (nothing printed)
    assert server.proc.returncode in (0, -signal.SIGINT) and "Traceback" not in log and "Error" not in log, log[-2000:]


# -- the page in Chromium ---------------------------------------------------------------------------------------------------


@pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium is not installed (apt-get install chromium)")
def test_the_page_works_in_chromium_and_other_pages_cannot_use_the_servers(serve, view):
    from test_view_browser import Browser

    browser = Browser()
    try:
        browser.open(view.url + "/")  # sgt view's page loads its take
        assert browser.state()["words"] > 3 and browser.state()["problem"] == ""
        before = health(serve)["pool"]
        # this page is another origin for sgt serve (another port): what a page of any site could try
        browser.js(f"""(() => {{
            window.attempts = {{}};
            fetch('{serve.url}/v1/generate', {{method: 'POST', mode: 'no-cors', headers: {{'Content-Type': 'text/plain'}},
                  body: JSON.stringify({{text: 'Hello there', timing: 'estimate'}})}}).then(() => attempts.fetch = 'sent',
                  (e) => attempts.fetch = 'failed');
            const ws = new WebSocket('ws://127.0.0.1:{serve.port}/v1/stream');
            ws.onopen = () => attempts.ws = 'open';
            ws.onclose = () => attempts.ws = attempts.ws || 'refused';
            const frame = document.createElement('iframe');
            frame.name = 'sink';
            document.body.appendChild(frame);
            const form = document.createElement('form');
            form.method = 'POST'; form.enctype = 'multipart/form-data'; form.target = 'sink';
            form.action = '{serve.url}/v1/generate/upload';
            form.innerHTML = '<input name="request" value=\\'{{"text": "hello there"}}\\'>';
            document.body.appendChild(form);
            form.submit();
        }})()""")
        browser.wait("attempts.fetch && attempts.ws", 15, "the fetch and the WebSocket to end")
        time.sleep(1)  # the form's post
        assert browser.js("attempts.ws") == "refused"
        statuses = {e["params"]["response"]["url"]: e["params"]["response"]["status"]
                    for e in browser.events if e.get("method") == "Network.responseReceived"}
        assert statuses.get(serve.url + "/v1/generate/upload") == 403, statuses
        assert health(serve)["pool"] == before and health(serve)["streams"]["open"] == 0  # none of it did any work
        # DNS rebinding: Chromium sends *.localhost to 127.0.0.1 itself, with that name as Host
        browser.cmd("Page.navigate", url=f"http://rebound.localhost:{view.port}/")
        browser.wait("document.body && document.body.innerText.includes('does not answer to that Host')", 15,
                     "the rebound page's refusal")
        assert WORD not in browser.js("document.body.innerText") and not browser.js("!!window.sgtView")
        # sgt serve's page generates (its POST is same-origin JSON)
        browser.cmd("Page.navigate", url=serve.url + "/view/")
        browser.wait("!!(window.sgtView && document.getElementById('generate'))", 30, "sgt serve's page")
        browser.js(f"document.getElementById('script').value = {json.dumps(SCRIPT)}")
        browser.click("#generate")
        browser.wait("sgtView.ready && sgtView.state().words > 3", 60, "the generated take")
        assert browser.state()["problem"] == ""
        assert health(serve)["pool"]["completed"] == before["completed"] + 1
    finally:
        browser.close()

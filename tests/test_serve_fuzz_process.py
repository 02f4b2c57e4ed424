"""A fuzz run against a real `sgt serve` process on 127.0.0.1: random and mutated JSON, hostile
voices, mutated scripts, uploads, malformed HTTP and WebSocket frames, from a seeded generator
(the same run every time), bounded in count and in time.

Every HTTP answer is JSON and never a 500 (a 408 or 503 under load is allowed); the server is
still answering at the end, never logged a traceback, and its memory grew by less than a bound.
tests/test_serve_fuzz.py fuzzes the application in-process with hypothesis; this one fuzzes
the process a client talks to (the socket, uvicorn, the speech worker, the stream).
"""

from __future__ import annotations

import importlib.util
import json
import random
import socket
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from test_fuzz import EXAMPLES

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("bench_serve", ROOT / "benchmarks" / "bench_serve.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)

#: The run's bounds: requests, WebSocket sessions, seconds (whichever ends first), and how much
#: the server's resident memory may grow over the run.
REQUESTS, SESSIONS, SECONDS, GROWTH_MB = 300, 30, 120.0, 150.0
VOICES = ["en-us", "en-us+m3", "en-us+" + "a" * 40, "en-us+../../../../etc/passwd", "en-us+zz9", "zz", "en-us+m3+f2",
          "", "x" * 70, "en-us+\u00e9", "EN-GB+F2", "en-us+%s", "en-us+;rm -rf /"]
VALID = {"text": "Hello there, welcome to the mall.", "timing": "estimate", "engine": "keyframe", "seed": 1}


def mutate(rng: random.Random, text: str, n: int = 3) -> str:
    chars = list(text)
    for _ in range(rng.randint(1, n)):
        op, at = rng.random(), rng.randrange(len(chars) + 1)
        if op < 0.4 and chars:
            del chars[min(at, len(chars) - 1)]
        elif op < 0.8:
            chars.insert(at, rng.choice('{}[]",:\\\x00\n é0-9aZ<>@+/'))
        elif chars:
            chars[min(at, len(chars) - 1)] = chr(rng.randrange(1, 0x3000))
    return "".join(chars)


def random_json(rng: random.Random, depth: int = 0):
    kind = rng.randrange(7 if depth < 4 else 4)
    if kind == 0:
        return None
    if kind == 1:
        return rng.choice([True, False, 0, -1, 2**70, 1e308, -0.0, 3.5])
    if kind == 2:
        return "".join(chr(rng.randrange(1, 0x2FFF)) for _ in range(rng.randrange(12)))
    if kind == 3:
        return rng.choice(list(VALID) + ["script", "voice", "style", "words", "outputs", "utterances"])
    if kind in (4, 5):
        return [random_json(rng, depth + 1) for _ in range(rng.randrange(4))]
    return {random_json(rng, 4) if rng.random() < 0.3 else rng.choice(["text", "script", "voice", "style", "seed", "words"]):
            random_json(rng, depth + 1) for _ in range(rng.randrange(4))}


def request_body(rng: random.Random) -> tuple[str, bytes, str]:
    """(endpoint, body, content type) of one fuzzed request."""
    kind = rng.randrange(8)
    if kind == 0:
        return "/v1/generate", bytes(rng.randrange(256) for _ in range(rng.randrange(200))), "application/json"
    if kind == 1:
        return "/v1/generate", mutate(rng, json.dumps(VALID), 6).encode("utf-8", "surrogatepass"), "application/json"
    if kind == 2:
        body = dict(VALID, voice=rng.choice(VOICES), timing=rng.choice(["estimate", "speech"]))
        return "/v1/generate", json.dumps(body).encode(), "application/json"
    if kind == 3:
        script = mutate(rng, rng.choice(EXAMPLES), 4)
        if rng.random() < 0.5:
            script = f"@voice {rng.choice(VOICES)}\n" + script
        endpoint = rng.choice(["/v1/check", "/v1/generate"])
        body = {"script": script} if endpoint == "/v1/check" else {"script": script, "timing": "estimate", "engine": "keyframe"}
        return endpoint, json.dumps(body).encode(), "application/json"
    if kind == 4:
        return rng.choice(["/v1/generate", "/v1/check"]), json.dumps(random_json(rng)).encode(), "application/json"
    if kind == 5:  # an upload: a request field, a recording that is not one, timings nested deep or broken
        boundary = "fuzzboundary"
        timings = rng.choice(["[" * 5000 + "]" * 5000, '[{"word": "hi", "start": 0, "end": "x"}]', "{}", "\x00"])
        parts = [("request", None, json.dumps({"text": "hi there", "timing": "speech"}).encode()),
                 ("audio", "a.wav", bytes(rng.randrange(256) for _ in range(rng.randrange(1, 400)))),
                 ("timings", "t.json", timings.encode())]
        body = b"".join(f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"'.encode()
                        + (f'; filename="{fn}"'.encode() if fn else b"") + b"\r\n\r\n" + data + b"\r\n"
                        for name, fn, data in parts) + f"--{boundary}--\r\n".encode()
        return "/v1/generate/upload", body, f"multipart/form-data; boundary={boundary}"
    if kind == 6:
        return "/v1/generate", json.dumps({"text": mutate(rng, "hello [there] <speed:3> @voice # x", 5), "timing": "estimate",
                                           "engine": rng.choice(["keyframe", "rules", "neural"])}).encode(), "application/json"
    return "/v1/generate", json.dumps(dict(VALID, style={"speed": rng.choice([3, -3, 1e9, "x"])})).encode(), rng.choice(
        ["application/json", "text/plain", ""])


def post(url: str, body: bytes, content_type: str) -> tuple[int, bytes]:
    headers = {"Content-Type": content_type} if content_type else {}
    if url.endswith("/upload"):
        headers["X-Requested-With"] = "sgt"  # as a program sends an upload (a form cannot)
    req = urllib.request.Request(url, data=body, headers=headers)
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def raw_http(port: int, rng: random.Random) -> None:
    """Malformed HTTP on a raw socket: garbage, a huge header, a lying Content-Length."""
    junk = rng.choice([b"\x00\xff" * 50, b"GET / HTTP/9.9\r\n\r\n", b"POST /v1/generate HTTP/1.1\r\nContent-Length: 99999999\r\n\r\n{",
                       b"GET /healthz HTTP/1.1\r\nX: " + b"a" * 70000 + b"\r\n\r\n", b"\r\n\r\n\r\n"])
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        try:
            s.sendall(junk)
            s.settimeout(3)
            s.recv(1000)
        except OSError:
            pass


def websocket_session(url: str, rng: random.Random) -> None:
    from websockets.exceptions import WebSocketException
    from websockets.sync.client import connect

    messages = [{"type": "start", "seed": rng.choice([0, -1, "x", 2**40])}, {"type": "text", "text": mutate(rng, "hello there friend ", 3)},
                {"type": "words", "words": [{"word": "hi", "start": rng.choice([0, -1, 1e9]), "end": 0.5}]},
                {"type": "audio", "pcm16": rng.choice(["AAAA", "!!", "A" * 1001]), "sample_rate": rng.choice([16000, 7])},
                {"type": "time", "t": rng.choice([1.0, -5, "x", 1e12])}, random_json(rng), {"type": "end"}]
    try:
        with connect(url.replace("http://", "ws://") + "/v1/stream", open_timeout=10, close_timeout=2) as ws:
            for _ in range(rng.randrange(1, 8)):
                choice = rng.random()
                if choice < 0.1:
                    ws.send(bytes(rng.randrange(256) for _ in range(20)))  # a binary frame
                elif choice < 0.2:
                    ws.send(mutate(rng, json.dumps(rng.choice(messages)), 3))
                else:
                    ws.send(json.dumps(rng.choice(messages)))
                reply = json.loads(ws.recv(timeout=30))
                assert isinstance(reply, dict) and "type" in reply
    except (WebSocketException, TimeoutError, OSError):
        pass  # the server may close a stream it has had enough of; the checks below see it alive


@pytest.mark.slow
def test_the_service_survives_a_fuzz_run_and_its_memory_is_bounded(tmp_path):
    rng = random.Random(21)
    with bench.Server("--max-text", "5000", env={"SGT_CACHE_DIR": str(tmp_path / "cache")}) as server:
        assert post(server.url + "/v1/generate", json.dumps(dict(VALID, engine="neural", timing="speech")).encode(),
                    "application/json")[0] == 200  # warm: the model, the speech worker
        base = server.rss_mb()
        deadline = time.monotonic() + SECONDS
        statuses: dict[int, int] = {}
        for n in range(REQUESTS):
            if time.monotonic() > deadline:
                break
            if n % 25 == 0:
                raw_http(server.port, rng)
            if n % (REQUESTS // SESSIONS) == 0:
                websocket_session(server.url, rng)
            endpoint, body, content_type = request_body(rng)
            status, answer = post(server.url + endpoint, body, content_type)
            statuses[status] = statuses.get(status, 0) + 1
            assert status != 500 and status < 600, (endpoint, body[:300], answer[:300])
            doc = json.loads(answer)
            assert isinstance(doc, dict) and (status == 200 or isinstance(doc.get("error"), str)), answer[:300]
        assert sum(statuses.values()) >= 100, statuses
        assert 200 in statuses and 422 in statuses  # the run reached both the work and the refusals
        assert bench.post(server.url + "/v1/generate", dict(VALID))[0] == 200
        grown = server.rss_mb() - base
        code, err = server.stop()
    assert grown < GROWTH_MB, f"the server grew by {grown:.0f} MB over the run"
    assert code == 0 and "Traceback" not in err, err[-2000:]

"""sgt serve as a real process: uvicorn on 127.0.0.1, curl as the client, a clean shutdown; and
(marked slow) a bounded load test: 8 concurrent clients on loopback, no errors.

benchmarks/bench_serve.py runs the same load for 60 s and prints the figures docs/serve.md quotes.
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("bench_serve", ROOT / "benchmarks" / "bench_serve.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)
TOKEN = "curl-test-token-0123456789abcdef"


def curl(*args: str) -> tuple[int, dict]:
    """(HTTP status, JSON body) of a curl call."""
    r = subprocess.run(["curl", "-s", "-w", "\n%{http_code}", *args], capture_output=True, text=True, timeout=120)
    body, _, status = r.stdout.rpartition("\n")
    return int(status), json.loads(body)


@pytest.fixture(scope="module")
def server():
    with bench.Server("--token", TOKEN) as s:
        yield s
        code, err = s.stop()
        assert code == 0, err
        assert "Traceback" not in err, err


def test_curl_generate_check_library_and_refusals(server, tmp_path):
    auth = ["-H", f"Authorization: Bearer {TOKEN}"]
    status, health = curl(server.url + "/healthz")
    assert status == 200 and health["runtime"] == "onnx"
    status, body = curl(*auth, "-X", "POST", "-H", "Content-Type: application/json",
                        "-d", '{"text": "Hello there, welcome!", "timing": "estimate", "seed": 2}', server.url + "/v1/generate")
    assert status == 200
    u = body["motion"]["utterances"][0]
    assert u["text"] == "Hello there, welcome!" and len(u["poses"]) == len(u["positions"]) > 10
    status, body = curl(*auth, "-H", "Content-Type: application/json", "-d", '{"script": "g: hi [pose:wavee]"}',
                        server.url + "/v1/check")
    assert status == 200 and body["ok"] is False and body["diagnostics"][0]["code"] == "SGT201"
    status, body = curl(*auth, server.url + "/v1/library")
    assert status == 200 and any(g["name"] == "wave" for g in body["gestures"])
    status, body = curl("-H", "Content-Type: application/json", "-d", '{"text": "hi"}', server.url + "/v1/generate")
    assert status == 401 and "token" in body["error"]
    status, body = curl(*auth, "-H", "Content-Type: application/json", "-d", '{"script": "@audio /etc/shadow\\nbot: hi"}',
                        server.url + "/v1/generate")
    assert status == 403 and body["diagnostics"][0]["code"] == "SGT406"
    status, body = curl(*auth, "-H", "Content-Type: application/json", "-d", '{"text": ', server.url + "/v1/generate")
    assert status == 422 and body["error"]
    import numpy as np

    from dsl.speech.audio import wav_bytes

    (tmp_path / "hello.wav").write_bytes(wav_bytes(np.sin(np.arange(20000) / 7.0) * 0.3, 16000))
    status, body = curl(*auth, "-F", 'request={"text": "hello there", "words": [{"word": "hello", "start": 0.1, "end": 0.5}, '
                        '{"word": "there", "start": 0.6, "end": 1.0}]}', "-F", f"audio=@{tmp_path / 'hello.wav'}",
                        server.url + "/v1/generate/upload")
    assert status == 200, body
    assert [w["word"] for w in body["motion"]["utterances"][0]["words"]] == ["hello", "there"]


@pytest.mark.slow
def test_load_8_clients_no_errors_and_bounded():
    with bench.Server("--workers", "2", "--queue", "16") as server:
        bench.post(server.url + "/v1/generate", {"text": bench.SENTENCES[0]})
        result = bench.load(server.url, clients=8, seconds=8, max_requests=200)
        code, err = server.stop()
    assert result["requests"] >= 8 and result["errors"] == 0, result
    assert result["requests"] <= 200 + 8
    assert code == 0 and "Traceback" not in err

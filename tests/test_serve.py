"""sgt serve: endpoints, limits, refusals, the token, and the streaming protocol, through a real
HTTP client (Starlette's TestClient on the ASGI app; tests/test_serve_process.py runs uvicorn)."""

from __future__ import annotations

import base64
import io
import json
import threading
import wave

import numpy as np
import pytest
from fastapi.testclient import TestClient

from core.motion import load_motion
from dsl import compile_text
from dsl.plain import plain_script
from model.generate import generate
from model.streaming import LOOKAHEAD_S
from sgt_tui.cli import main
from sgt_tui.serve import jobs
from sgt_tui.serve.app import create_app
from sgt_tui.serve.config import ConfigError, ServeConfig, checked

TOKEN = "a-test-token-of-32-characters-xx"
SCRIPT = "@seed 4\nguide: Hello [pose:wave] there.\nguide: <speed:1>Again</speed>, once more.\n"


def client(**settings) -> TestClient:
    return TestClient(create_app(checked(ServeConfig(**settings))), raise_server_exceptions=False)


def upload(c: TestClient, data: dict, files: dict):
    """POST /v1/generate/upload as a program does: with a header no HTML form can send (docs/serve.md)."""
    return c.post("/v1/generate/upload", data=data, files=files, headers={"X-Requested-With": "sgt"})


@pytest.fixture(scope="module")
def api():
    with client() as c:
        yield c


def test_health_library_and_openapi(api):
    health = api.get("/healthz").json()
    assert health["status"] == "ok" and health["runtime"] == "onnx"
    gestures = {g["name"]: g for g in api.get("/v1/library").json()["gestures"]}
    assert "wave" in gestures and gestures["wave"]["description"]
    spec = api.get("/openapi.json").json()
    assert {"/v1/generate", "/v1/generate/upload", "/v1/check", "/v1/library", "/healthz"} <= set(spec["paths"])
    assert api.get("/docs").status_code == 200


def test_check_answers_what_sgt_check_says(api):
    text = "guide: Hello [pose:wavee] there.\nguide: fine\n"
    answer = api.post("/v1/check", json={"script": text}).json()
    expected = compile_text(text, timing="estimate").diagnostics
    assert answer["ok"] is False and answer["utterances"] == 2
    assert [(d["code"], d["line"], d["col"], d["message"]) for d in answer["diagnostics"]] == \
        [(d.code, d.line, d.col, d.message) for d in expected]
    assert answer["diagnostics"][0]["file"] == "<request>"
    assert api.post("/v1/check", json={"script": "guide: fine.\n"}).json() == {"ok": True, "utterances": 1, "diagnostics": []}


def test_generate_from_a_script_is_the_python_api_result(api):
    r = api.post("/v1/generate", json={"script": SCRIPT, "timing": "estimate"})
    assert r.status_code == 200
    motion = r.json()["motion"]
    take = generate(source=SCRIPT, timing="estimate")
    assert len(motion["utterances"]) == len(take.clips) == 2
    for got, clip in zip(motion["utterances"], take.clips):
        assert np.abs(np.array(got["poses"]) - clip.poses).max() < 1e-5  # JSON keeps 5 decimals
        assert got["text"] == clip.text
        assert got["start"] == pytest.approx(clip.start)  # on the performance clock
    # every speaker's continuous track, as sgt generate writes it
    assert [t["speaker"] for t in motion["tracks"]] == [t.speaker for t in take.tracks]
    assert np.abs(np.array(motion["tracks"][0]["poses"]) - take.tracks[0].poses).max() < 1e-5
    assert r.json()["timing"] == "estimate"
    seeded = api.post("/v1/generate", json={"script": SCRIPT, "timing": "estimate", "seed": 9, "utterances": [1]}).json()
    other = generate(source=SCRIPT, timing="estimate", seed=9, utterances=[1]).clips
    assert len(seeded["motion"]["utterances"]) == 1
    assert np.abs(np.array(seeded["motion"]["utterances"][0]["poses"]) - other[0].poses).max() < 1e-5


def test_generate_from_plain_text_speaks_it_as_is(api, tmp_path):
    text = "Press [enter] <now> # or @audio later: fine"
    body = {"text": text, "speaker": "robot", "rate": 150, "style": {"speed": 1.5}, "seed": 3, "engine": "keyframe",
            "timing": "estimate", "outputs": ["bvh", "glb"]}
    answer = api.post("/v1/generate", json=body).json()
    u = answer["motion"]["utterances"][0]
    assert u["speaker"] == "robot" and u["text"] == text
    assert [c["kind"] for c in u["controls"]] == ["style"]
    expected = generate(source=plain_script(text, speaker="robot", rate=150, style={"speed": 1.5}), seed=3,
                        engine="keyframe", timing="estimate").clips[0]
    assert np.abs(np.array(u["poses"]) - expected.poses).max() < 1e-5
    assert answer["outputs"]["bvh"][0].startswith("HIERARCHY")
    assert base64.b64decode(answer["outputs"]["glb"][0])[:4] == b"glTF"
    (tmp_path / "m.json").write_text(json.dumps(answer["motion"]))
    assert load_motion(tmp_path / "m.json")[0].n_frames == expected.n_frames  # a valid motion file


@pytest.mark.slow
def test_generate_with_speech_returns_the_speech(api):
    answer = api.post("/v1/generate", json={"text": "Hello there.", "outputs": ["wav"]}).json()
    assert answer["timing"] == "espeak-ng"
    wav = answer["outputs"]["wav"][0]
    with wave.open(io.BytesIO(base64.b64decode(wav["data"]))) as w:
        assert w.getnframes() > 0
    assert wav["lead_in"] >= 0


def test_uploaded_recording_with_word_timings(api):
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(1), w.setsampwidth(2), w.setframerate(16000)
        w.writeframes((np.sin(np.arange(24000) / 9.0) * 8000).astype("<i2").tobytes())
    request = {"text": "hello there", "words": [{"word": "hello", "start": 0.2, "end": 0.6},
                                                {"word": "there", "start": 0.7, "end": 1.2}], "seed": 1}
    r = upload(api, {"request": json.dumps(request)}, {"audio": ("take.wav", buf.getvalue())})
    assert r.status_code == 200, r.json()
    u = r.json()["motion"]["utterances"][0]
    assert [w["word"] for w in u["words"]] == ["hello", "there"]
    assert r.json()["timing"] == "json"  # from the word timings sent
    request["words"][1]["word"] = "where"  # timings that do not match the transcript: the compiler's diagnostic
    bad = upload(api, {"request": json.dumps(request)}, {"audio": ("take.wav", buf.getvalue())})
    assert bad.status_code == 422 and bad.json()["diagnostics"][0]["code"] == "SGT404"
    wrong_kind = upload(api, {"request": json.dumps(request)}, {"audio": ("take.exe", b"MZ")})
    assert wrong_kind.status_code == 415
    no_text = upload(api, {"request": json.dumps({"script": "a: b"})}, {"audio": ("a.wav", b"")})
    assert no_text.status_code == 422


@pytest.mark.parametrize("script, directive, col", [
    ("@audio /etc/passwd\nbot: hi", "audio", 8),
    ("@library /etc\nbot: hi", "library", 10),
    ("@audio ok.wav timings=/etc/hosts\nbot: hi", "audio", 23),
    ("@audio ../outside.wav\nbot: hi", "audio", 8),
    ("@audio ~/x.wav\nbot: hi", "audio", 8),
])
def test_paths_outside_the_allowed_folders_are_refused_unopened(tmp_path, script, directive, col):
    allowed = tmp_path / "voices"
    allowed.mkdir()
    (allowed / "ok.wav").write_bytes(b"")
    for settings in ({}, {"allow": (allowed,)}):
        with client(**settings) as c:
            for endpoint in ("/v1/generate", "/v1/check"):
                r = c.post(endpoint, json={"script": script, **({"timing": "estimate"} if "generate" in endpoint else {})})
                assert r.status_code == 403, r.json()
                d = next(d for d in r.json()["diagnostics"] if d["col"] == col)
                assert d["code"] == "SGT406" and d["line"] == 1 and d["file"] == "<request>"
                assert f"@{directive}" in d["hint"]
                assert str(tmp_path) not in json.dumps(r.json())  # the server's folders are not revealed


def test_files_in_an_allowed_folder_are_read_and_links_out_of_it_are_not(tmp_path):
    allowed = tmp_path / "voices"
    allowed.mkdir()
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(1), w.setsampwidth(2), w.setframerate(22050)
        w.writeframes(np.zeros(30000, "<i2").tobytes())
    (allowed / "l1.wav").write_bytes(buf.getvalue())
    (allowed / "l1.json").write_text('[{"word": "hi", "start": 0.1, "end": 0.5}]')
    outside = tmp_path / "secret.wav"
    outside.write_bytes(buf.getvalue())
    (allowed / "link.wav").symlink_to(outside)
    with client(allow=(allowed,)) as c:
        ok = c.post("/v1/generate", json={"script": "@audio l1.wav timings=l1.json\nbot: hi", "seed": 0})
        assert ok.status_code == 200, ok.json()
        assert ok.json()["timing"] == "json"
        linked = c.post("/v1/generate", json={"script": "@audio link.wav timings=l1.json\nbot: hi"})
        assert linked.status_code == 403


def test_a_token_is_required_when_set_and_when_exposed(monkeypatch):
    with pytest.raises(ConfigError, match="token"):
        checked(ServeConfig(host="0.0.0.0"))
    with pytest.raises(ConfigError, match="at least 16"):
        checked(ServeConfig(token="short"))
    monkeypatch.setenv("SGT_SERVE_TOKEN", TOKEN)
    assert checked(ServeConfig(host="0.0.0.0")).token == TOKEN
    with client(host="0.0.0.0") as c:
        assert c.get("/healthz").status_code == 200  # says only "up"
        body = {"text": "hi", "timing": "estimate"}
        for headers in ({}, {"Authorization": "Bearer wrong"}, {"Authorization": TOKEN}, {"Authorization": f"Basic {TOKEN}"}):
            r = c.post("/v1/generate", json=body, headers=headers)
            assert r.status_code == 401 and r.headers["www-authenticate"] == "Bearer"
        assert c.get("/v1/library").status_code == 401
        assert c.post("/v1/generate", json=body, headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200
        with pytest.raises(Exception):  # the handshake is refused
            with c.websocket_connect("/v1/stream") as ws:
                ws.send_json({"type": "start"})
                ws.receive_json()
        with c.websocket_connect("/v1/stream", headers={"Authorization": f"Bearer {TOKEN}"}) as ws:
            ws.send_json({"type": "start"})
            assert ws.receive_json()["type"] == "ready"


def test_sgt_serve_refuses_to_expose_itself_without_a_token(capsys, monkeypatch):
    import uvicorn

    def started(*args, **kwargs):
        raise AssertionError("sgt serve started listening")  # never hang the suite on a real server

    monkeypatch.setattr(uvicorn, "run", started)
    monkeypatch.delenv("SGT_SERVE_TOKEN", raising=False)
    assert main(["serve", "--host", "0.0.0.0"]) == 2
    assert "token" in capsys.readouterr().err
    assert main(["serve", "--allow", "/no/such/folder"]) == 2


def test_size_and_duration_limits(tmp_path):
    with client(max_body=4096, max_text=300) as c:
        big = {"text": "word " * 1000}
        assert c.post("/v1/generate", json=big).status_code == 413
        chunked = c.post("/v1/generate", content=(b"x" * 1000 for _ in range(10)), headers={"Content-Type": "application/json"})
        assert chunked.status_code == 413  # no Content-Length: counted while reading
        r = c.post("/v1/generate", json={"text": "word " * 100, "timing": "estimate"})
        assert r.status_code == 413 and "at most 300" in r.json()["error"]
    with client(timeout=0.001) as c:
        r = c.post("/v1/generate", json={"text": "hello there " * 20, "timing": "estimate"})
        assert r.status_code == 408 and "longer" in r.json()["error"]


def test_a_full_queue_answers_503_with_retry_after(monkeypatch):
    release = threading.Event()
    started = threading.Event()

    def slow(*args):
        started.set()
        release.wait(30)
        return {"ok": True}

    monkeypatch.setattr(jobs, "generate_request", slow)
    import sgt_tui.serve.app as app_module

    monkeypatch.setattr(app_module, "generate_request", slow)
    with client(workers=1, queue=1) as c:
        body = {"text": "hi", "timing": "estimate"}
        results = []
        threads = [threading.Thread(target=lambda: results.append(c.post("/v1/generate", json=body).status_code)) for _ in range(2)]
        threads[0].start()
        assert started.wait(10)
        threads[1].start()  # waits in the queue
        for _ in range(100):
            if c.get("/healthz").json()["pool"]["admitted"] == 2:
                break
            threading.Event().wait(0.05)
        full = c.post("/v1/generate", json=body)
        assert full.status_code == 503 and int(full.headers["retry-after"]) >= 1
        release.set()
        for t in threads:
            t.join(30)
        assert results == [200, 200]
        assert c.get("/healthz").json()["pool"]["rejected"] == 1


@pytest.mark.parametrize("body, status, where", [
    ({"script": "a: b", "text": "c"}, 422, "body"),
    ({}, 422, "body"),
    ({"text": "hi", "engine": "magic"}, 422, "engine"),
    ({"text": "hi", "rate": 20}, 422, "rate"),
    ({"text": "hi", "seed": -1}, 422, "seed"),
    ({"text": "hi", "style": {"speed": 9}}, 422, "style.speed"),
    ({"text": "hi", "speaker": "two words"}, 422, None),
    ({"script": "a: b", "voice": "en-gb"}, 422, "body"),
    ({"text": "hi", "colour": "red"}, 422, "colour"),
    ({"script": "guide: Hello [pose:wavee] there.", "timing": "estimate"}, 422, None),
    ({"script": "guide: hi", "utterances": [5], "timing": "estimate"}, 422, None),
])
def test_bad_requests_get_a_4xx_that_says_what_is_wrong(api, body, status, where):
    r = api.post("/v1/generate", json=body)
    assert r.status_code == status
    answer = r.json()
    assert answer["error"] and "Traceback" not in r.text
    if where:
        assert where in [d["where"] for d in answer["diagnostics"]]


def test_script_errors_come_back_as_diagnostics(api):
    answer = api.post("/v1/generate", json={"script": "guide: Hello [pose:wavee] there.", "timing": "estimate"}).json()
    d = answer["diagnostics"][0]
    assert (d["code"], d["line"], d["col"], d["file"]) == ("SGT201", 1, 20, "<request>")
    assert "did you mean" in d["hint"].lower() or d["suggestions"]


def test_unknown_paths_and_methods_are_json(api):
    assert api.get("/nope").status_code == 404 and api.get("/nope").json()["error"]
    assert api.get("/v1/generate").status_code == 405 and api.get("/v1/generate").json()["error"]


def test_an_unexpected_failure_is_a_500_without_a_traceback(monkeypatch, api):
    import sgt_tui.serve.app as app_module

    def broken(*args):
        raise RuntimeError("secret internal detail")

    monkeypatch.setattr(app_module, "check", broken)
    r = api.post("/v1/check", json={"script": "a: b"})
    assert r.status_code == 500 and "secret" not in r.text and "Traceback" not in r.text
    assert r.json() == {"error": "internal error; the server's log has the details"}


# -- streaming ------------------------------------------------------------------------------

def frames_of(replies):
    return [m for m in replies if m["type"] == "frames"]


def receive_until(ws, kind):
    out = []
    while True:
        m = ws.receive_json()
        out.append(m)
        if m["type"] == kind:
            return out


def test_stream_of_timed_words(api):
    words = list(compile_text("guide: Welcome to the mall, the shops are over there.", timing="estimate").plan.utterances[0].words)
    with api.websocket_connect("/v1/stream") as ws:
        ws.send_json({"type": "start", "seed": 2})
        ready = ws.receive_json()
        assert ready["type"] == "ready" and ready["fps"] == 15 and ready["lookahead_s"] == pytest.approx(LOOKAHEAD_S, abs=1e-4)
        for w in words:
            ws.send_json({"type": "words", "words": [w.to_dict(6)]})
        ws.send_json({"type": "end"})
        replies = receive_until(ws, "done")
    frames = frames_of(replies)
    assert [f["start"] for f in frames] == list(np.cumsum([0] + [len(f["poses"]) for f in frames[:-1]]))
    poses = np.concatenate([np.array(f["poses"]) for f in frames])
    assert replies[-1]["frames"] == len(poses) > 40
    assert np.allclose(np.linalg.norm(poses.reshape(-1, 9, 3), axis=-1), 1.0, atol=1e-4)
    positions = np.concatenate([np.array(f["positions"]) for f in frames])
    assert positions.shape == (len(poses), 10, 3)
    for f in frames[:-1]:  # every frame sent before the end had its lookahead known
        last = f["start"] + len(f["poses"]) - 1
        assert f["known_until"] >= last / 15 + LOOKAHEAD_S - 1e-3


def test_stream_of_text_as_an_llm_produces_it(api):
    with api.websocket_connect("/v1/stream") as ws:
        ws.send_json({"type": "start", "rate": 150})
        ws.receive_json()
        timed = []
        for chunk in ["Hel", "lo the", "re, how a", "re you to", "day? Fine."]:
            ws.send_json({"type": "text", "text": chunk})
        ws.send_json({"type": "end"})
        replies = receive_until(ws, "done")
    timed = [w for m in replies if m["type"] == "timed" for w in m["words"]]
    assert [w["word"] for w in timed] == ["Hello", "there", "how", "are", "you", "today", "Fine"]
    starts = [w["start"] for w in timed]
    assert starts == sorted(starts) and all(w["end"] > w["start"] for w in timed)
    assert timed[-2]["end"] < timed[-1]["start"] - 0.2  # the estimate's pause after a sentence
    assert replies[-1]["frames"] == sum(len(m["poses"]) for m in frames_of(replies))


def test_long_text_messages_are_timed_or_refused_for_what_they_are(api):
    """A text of more than 2000 characters with spaces was dropped for '2000 characters without
    a space'; a 900 KB one too. Now a 3000-character text is timed whole, a 900 KB one is
    refused for its size (nothing of it used), and only a 2000-character word is 'without a space'."""
    from sgt_tui.serve.stream import MAX_TEXT_MESSAGE

    with api.websocket_connect("/v1/stream") as ws:
        ws.send_json({"type": "start"})
        ws.receive_json()
        text = "the quick brown fox jumps over the lazy dog " * 70  # 3080 characters, 630 words
        ws.send_json({"type": "text", "text": text})
        first = ws.receive_json()
        assert first["type"] == "timed" and len(first["words"]) == 630
        ws.send_json({"type": "text", "text": "word " * 180_000})  # 900 KB
        replies = receive_until(ws, "error")
        assert f"at most {MAX_TEXT_MESSAGE} characters" in replies[-1]["message"]
        ws.send_json({"type": "text", "text": "x" * 2500})
        assert "without a space" in receive_until(ws, "error")[-1]["message"]
        ws.send_json({"type": "end"})
        assert receive_until(ws, "done")[-1]["type"] == "done"


def test_stream_of_audio_chunks_with_their_words(api):
    """A TTS's audio at 22.05 kHz in chunks of 0.2 s, each with the words that start in it: the
    frames are those the generator decides from the same audio and words (resampled in pieces
    as the whole), never ahead of the audio, and the last one comes at the end."""
    import base64

    from core.words import TimedWord
    from dsl.speech.audio import read_wav, resample_poly
    from model.features import SAMPLE_RATE
    from model.runtime import load_runner
    from model.streaming import StreamGenerator

    u = compile_text("guide: Welcome to the mall, the shops are over there.").plan.utterances[0]
    data, rate = read_wav(u.audio_path)
    pcm = np.round(data[:, 0] * 32768).clip(-32768, 32767).astype("<i2")
    words = [w.to_dict(6) for w in u.words]  # the audio starts at the utterance's first frame here
    chunk = int(0.2 * rate)
    with api.websocket_connect("/v1/stream") as ws:
        ws.send_json({"type": "start", "seed": 4, "engine": "neural"})  # compared below with the network's own stream
        ws.receive_json()
        pending = list(words)
        for at in range(0, len(pcm), chunk):
            end = min(len(pcm), at + chunk) / rate
            starting = [w for w in pending if w["start"] < end]
            pending = pending[len(starting):]
            message = {"type": "audio", "sample_rate": rate,
                       "pcm16": base64.b64encode(pcm[at : at + chunk].tobytes()).decode("ascii")}
            ws.send_json({**message, "words": starting} if starting else message)
        ws.send_json({"type": "end"})
        replies = receive_until(ws, "done")
    assert not [m for m in replies if m["type"] == "error"]
    frames = frames_of(replies)
    poses = np.concatenate([np.array(f["poses"]) for f in frames])
    for f in frames[:-1]:  # decided before the end: the audio was known LOOKAHEAD_S past each frame
        assert (f["start"] + len(f["poses"]) - 1) / 15 + LOOKAHEAD_S <= f["known_until"] + 1e-3

    gen = StreamGenerator(load_runner(None), seed=4)
    gen.add_audio(resample_poly(pcm.astype(np.float32) / 32768.0, SAMPLE_RATE, rate).astype(np.float32))
    expected = np.concatenate([gen.add_words([TimedWord(w["word"], w["start"], w["end"]) for w in words]),
                               gen.known_until(len(pcm) / rate), gen.finish()])
    assert replies[-1]["frames"] == len(poses) == len(expected)
    assert np.allclose(poses, expected, atol=2e-5)


def test_stream_errors_are_messages_and_the_stream_goes_on(api):
    with api.websocket_connect("/v1/stream") as ws:
        ws.send_json({"type": "words", "words": []})
        assert "start" in ws.receive_json()["message"]
        ws.send_text("{not json")
        assert ws.receive_json()["type"] == "error"
        ws.send_json({"type": "start", "style": {"sped": 1}})
        assert "unknown style" in ws.receive_json()["message"]
        ws.send_json({"type": "start", "bogus": 1})
        assert "bogus" in ws.receive_json()["message"]
        ws.send_json({"type": "start"})
        assert ws.receive_json()["type"] == "ready"
        for bad in ({"type": "words", "words": [{"word": "a", "start": "x", "end": 1}]},
                    {"type": "words", "words": [{"word": "a", "start": 1e9, "end": 1e9}]},
                    {"type": "time", "t": -1}, {"type": "dance"}, ["a list"], {"type": "start"}):
            ws.send_json(bad)
            assert ws.receive_json()["type"] == "error"
        ws.send_bytes(b"\x00\x01")
        assert ws.receive_json()["type"] == "error"
        ws.send_json({"type": "time", "t": 2.0})
        assert frames_of([ws.receive_json()])
        for bad, why in (({"pcm16": "%%%"}, "base64"), ({"pcm16": "AA=="}, "even number"),
                         ({"pcm16": "AAAAAA==", "sample_rate": 12345}, "sample_rate"),
                         ({"pcm16": "AAAAAA==", "gain": 2}, "gain"), ({"pcm16": 5}, "pcm16")):
            ws.send_json({"type": "audio", **bad})
            assert why in ws.receive_json()["message"]
        ws.send_json({"type": "audio", "pcm16": "AAAAAA==", "sample_rate": 22050})
        ws.send_json({"type": "audio", "pcm16": "AAAAAA==", "sample_rate": 16000})
        assert "22050 Hz" in ws.receive_json()["message"]
        ws.send_json({"type": "end"})
        assert receive_until(ws, "done")[-1]["type"] == "done"


def test_a_generator_that_cannot_run_answers_503_without_the_servers_paths(tmp_path, caplog):
    """The matching database is checked when the service starts; one damaged later makes the
    requests that need it a 503 whose message names no server file (the log does)."""
    import shutil

    from model import matching  # lazy: numpy, the engine

    db = tmp_path / "mine.npz"
    shutil.copyfile(matching.DEFAULT_DB, db)
    with client(database=str(db)) as api:
        db.write_bytes(b"not a database")
        r = api.post("/v1/generate", json={"script": "guide: Hello there.", "engine": "matching", "timing": "estimate"})
    assert r.status_code == 503 and "cannot run" in r.json()["error"]
    assert "mine.npz" not in r.text and str(tmp_path) not in r.text and "mine.npz" in caplog.text

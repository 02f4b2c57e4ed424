"""sgt view without a browser: the page's data, its server (the take, the speech, VRM Animation,
the token), reloading a take whose files change, the command's refusals, the service's page,
and the vendored bundle (built from the committed sources, with its licences, nothing from
the network). tests/test_view_browser.py opens the page in headless Chromium."""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import re
import struct
import wave
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from core.face import ARKIT_INDEX, N_BLENDSHAPES
from core.motion import load_motion_file
from core.skeleton import FPS
from renders import face_rig
from renders.clips import speaker_name, track_clip
from renders.mannequin import VIEWS
from sgt_tui.cli import main
from sgt_tui.serve.app import create_app
from sgt_tui.serve.config import ServeConfig, checked
from sgt_tui.view.assets import STATIC
from sgt_tui.view.page import FACE_CHANNELS, page_take
from sgt_tui.view.server import create_view_app
from sgt_tui.view.takes import Viewer

ROOT = Path(__file__).resolve().parent.parent
TOKEN = "a-test-token-of-32-characters-xx"
DIALOGUE = ("@seed 3\nguide: Look at the shelf [pose:point_right] over there.\n"
            "visitor: Thanks, <speed:1>I see it</speed>.\n")


@pytest.fixture(scope="module")
def take(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("view")
    (folder / "talk.sgt").write_text(DIALOGUE)
    assert main(["generate", str(folder / "talk.sgt"), "-o", str(folder / "talk.json")]) == 0
    return folder / "talk.json"


def test_the_page_gets_every_speaker_on_the_performance_clock(take):
    motion = load_motion_file(take)
    doc = page_take(motion, "talk.json")
    n = motion.tracks[0].n_frames
    assert doc["frames"] == n and doc["duration"] == pytest.approx(n / FPS)
    assert [s["name"] for s in doc["speakers"]] == ["guide", "visitor"]
    assert doc["speakers"][0]["tint"] != doc["speakers"][1]["tint"]
    for s, track in zip(doc["speakers"], motion.tracks):
        assert len(s["positions"]) == n * 10 * 3 and len(s["hands"]) == n * 2 * 20 * 3
        assert np.allclose(np.reshape(s["positions"], (n, 10, 3)), track.positions, atol=6e-5)
    visitor = motion.clips[1]
    first = next(w for w in doc["words"] if w["speaker"] == "visitor")
    assert first["start"] == pytest.approx(visitor.start + visitor.words[0].start, abs=1e-4)
    point = next(c for c in doc["controls"] if c["kind"] == "pose")
    clip = track_clip(motion.tracks[0], motion.clips)
    assert point["name"] == "point_right" and point["stroke_frame"] == clip.controls[0].stroke_frame
    assert point["stroke"] == pytest.approx(point["stroke_frame"] / FPS)
    style = next(c for c in doc["controls"] if c["kind"] == "style")
    assert style["speaker"] == "visitor" and style["label"] == "speed:+1"
    assert doc["scene"]["views"] == {k: {"azimuth": v.azimuth, "elevation": v.elevation, "distance": v.distance,
                                         "on_head": v.on_head} for k, v in VIEWS.items()}


def test_the_pages_words_are_sgt_renders_to_the_bit(take):
    """The page captions a frame with the word whose span holds its middle, as sgt render does
    (renders.overlay.frame_word, viewer/src/caption.js): with the words' times rounded, a word that
    starts a hair after a frame's middle would caption that frame on the page and not in sgt's
    render. JSON carries a float exactly, so the page gets the very times sgt render has."""
    motion = load_motion_file(take)
    words = json.loads(json.dumps(page_take(motion, "talk.json")))["words"]
    for track in motion.tracks:
        clip = track_clip(track, motion.clips)
        own = [(w["word"], w["start"], w["end"]) for w in words if w["speaker"] == speaker_name(track.speaker)]
        assert own == [(w.word, w.start, w.end) for w in clip.words]


def test_the_page_gets_each_speakers_face_as_the_mannequin_draws_it(take):
    motion = load_motion_file(take)
    doc = page_take(motion, "talk.json")
    for s, track in zip(doc["speakers"], motion.tracks):
        face, n = s["face"], track.n_frames
        assert set(face["channels"]) <= set(FACE_CHANNELS) and "jawOpen" in face["channels"]
        assert not any(c.startswith("eyeLook") for c in face["channels"])  # the gaze says it
        weights = np.zeros((n, N_BLENDSHAPES))
        weights[:, [ARKIT_INDEX[c] for c in face["channels"]]] = np.reshape(face["weights"], (n, -1))
        drawn = [ARKIT_INDEX[c] for c in FACE_CHANNELS]
        assert np.allclose(weights[:, drawn], track.face.weights[:, drawn], atol=6e-4)  # a channel left out is 0
        gaze = np.reshape(face["gaze"], (n, 2, 2))
        assert np.allclose(gaze, track.face.gaze, atol=6e-3) and np.ptp(gaze) > 1
        # the page's face is sgt's: the parts' maps from what the page gets are those from the whole face
        ours = face_rig.part_transforms(track.face.weights, track.face.gaze, face_rig.GAZE_GAIN)
        assert np.allclose(face_rig.part_transforms(weights, gaze, face_rig.GAZE_GAIN), ours, atol=2e-5)
    assert len(json.dumps(doc["speakers"][0]["face"])) < 0.15 * len(json.dumps(doc["speakers"][0]))  # compact
    motion.tracks[1] = dataclasses.replace(motion.tracks[1], face=None)  # a speaker without a face
    speakers = page_take(motion, "talk.json")["speakers"]
    assert "face" in speakers[0] and "face" not in speakers[1]


@pytest.fixture(scope="module")
def viewer(take):
    return Viewer(take)


def test_the_server_serves_the_page_the_take_its_speech_and_vrm_animation(viewer):
    with TestClient(create_view_app(viewer, checked(ServeConfig(port=0)))) as c:
        page = c.get("/")
        assert page.status_code == 200 and 'data-mode="file"' in page.text
        for name in re.findall(r'(?:src|href)="([^"]+)"', page.text):  # the page's own files, nothing from elsewhere
            assert not re.match(r"[a-z]+://", name) and (name.startswith(("static/", "#")) or name == "data:,"), name
            if name.startswith("static/"):
                assert c.get("/" + name).status_code == 200
        assert c.get("/static/../takes.py").status_code == 404 and c.get("/static/index.html").status_code == 404
        doc = c.get("/api/take").json()
        status = c.get("/api/status").json()
        assert status["takes"][0]["name"] == "talk.json" and status["takes"][0]["error"] == ""
        assert doc["format"] == "sgt-view" and doc["id"] == status["takes"][0]["id"] == 1
        with wave.open(io.BytesIO(c.get(doc["audio"]).content)) as w:  # the speech, as long as the motion
            assert abs(w.getnframes() / w.getframerate() - doc["duration"]) < 1e-3
        vrma = c.get(doc["vrma"][1]).content
        assert vrma[:4] == b"glTF"
        (length,) = struct.unpack_from("<I", vrma, 12)
        assert "VRMC_vrm_animation" in json.loads(vrma[20:20 + length])["extensionsUsed"]
        assert c.get("/api/take?take=5").status_code == 404
        assert c.get("/api/vrma?speaker=2").status_code == 404
        assert c.get(f"/api/wait?version={status['version'] + 1}").json()["version"] == status["version"]  # answers at once


def test_a_token_guards_the_take_not_the_page(viewer):
    with TestClient(create_view_app(viewer, checked(ServeConfig(host="0.0.0.0", token=TOKEN)))) as c:
        assert c.get("/").status_code == 200 and c.get("/static/viewer.js").status_code == 200
        for path in ("/api/status", "/api/take", "/api/audio.wav", "/api/vrma"):
            assert c.get(path).status_code == 401
            assert c.get(path, headers={"Authorization": "Bearer wrong-token-of-enough-length"}).status_code == 401
        assert c.get("/api/status", headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200


def test_a_saved_script_is_generated_again_and_a_broken_one_keeps_its_take(tmp_path):
    script = tmp_path / "one.sgt"
    script.write_text("guide: Hello [pose:wave] there.\n")
    v = Viewer(script)
    loaded, first = v.take(0)
    words = [w["word"] for w in loaded.doc["words"]]
    assert words == ["Hello", "there"] and loaded.audio[:4] == b"RIFF"
    v.poll()
    assert v.take(0)[1] == first  # nothing changed: nothing loaded
    script.write_text("guide: Hello [pose:wave] there, and welcome.\n")
    v.poll()
    loaded, second = v.take(0)
    assert second == first + 1 and [w["word"] for w in loaded.doc["words"]][-1] == "welcome"
    script.write_text("guide: Hello [pose:wavee] there.\n")
    v.poll()
    status = v.status()["takes"][0]
    assert status["id"] == second and "1 error" in status["error"] and "unknown gesture 'wavee'" in status["details"]
    assert v.take(0)[0] is loaded  # the last take that worked is still shown


def test_a_build_folder_offers_the_takes_of_its_manifest(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "a.sgt").write_text("guide: Hello there.\n")
    (tmp_path / "src" / "b.sgt").write_text("guide: Good bye [pose:wave] now.\n")
    assert main(["build", str(tmp_path / "src"), "-o", str(tmp_path / "out"), "--wav", "--quiet"]) == 0
    v = Viewer(tmp_path / "out")
    assert [s["name"] for s in v.status()["takes"]] == ["a.json", "b.json"]
    loaded, _ = v.take(1)
    assert loaded.doc["words"][0]["word"] == "Good" and loaded.audio is not None  # the --wav speech, mixed


@pytest.mark.parametrize("argv, code, said", [
    (["view", "talk.json", "--host", "0.0.0.0"], 2, "token"),
    (["view", "missing.sgt"], 1, "no such file"),
    (["view", "talk.txt"], 2, "unknown input type"),
    (["view", "bad.sgt"], 1, "unknown gesture"),
])
def test_the_command_refuses_before_it_listens(take, argv, code, said, capsys, monkeypatch):
    monkeypatch.chdir(take.parent)
    monkeypatch.delenv("SGT_SERVE_TOKEN", raising=False)
    (take.parent / "talk.txt").write_text("x")
    (take.parent / "bad.sgt").write_text("guide: Hello [pose:wavee] there.\n")
    assert main(argv) == code
    assert said in capsys.readouterr().err


def test_sgt_serve_offers_the_page_to_its_clients():
    with TestClient(create_app(checked(ServeConfig(token=TOKEN))), raise_server_exceptions=False) as c:
        page = c.get("/view/")
        assert page.status_code == 200 and 'data-mode="service"' in page.text  # the page needs no token
        assert c.get("/view/static/viewer.js").status_code == 200
        assert c.get("/view", follow_redirects=False).headers["location"] == "/view/"
        body = {"script": "guide: Hello [pose:wave] there."}
        assert c.post("/v1/view", json=body).status_code == 401  # its take does
        r = c.post("/v1/view", json=body, headers={"Authorization": f"Bearer {TOKEN}"})
        doc = r.json()
        assert r.status_code == 200 and doc["format"] == "sgt-view" and doc["speakers"][0]["name"] == "guide"
        assert doc["audio"].startswith("data:audio/wav;base64,") and doc["vrma"][0].startswith("data:model/gltf-binary;base64,")
        bad = c.post("/v1/view", json={"script": "guide: Hello [pose:wavee] there."}, headers={"Authorization": f"Bearer {TOKEN}"})
        assert bad.status_code == 422 and bad.json()["diagnostics"][0]["code"] == "SGT201"


def _sources_digest() -> str:
    """What viewer/build.mjs writes in the bundle's first line."""
    h = hashlib.sha256()
    for name in sorted(p.name for p in (ROOT / "viewer" / "src").glob("*.js")):
        h.update(f"src/{name}\0".encode())
        h.update((ROOT / "viewer" / "src" / name).read_bytes())
        h.update(b"\0")
    h.update(b"package-lock.json\0")
    h.update((ROOT / "viewer" / "package-lock.json").read_bytes())
    h.update(b"\0")
    return h.hexdigest()


def test_the_bundle_is_built_from_the_committed_sources_with_their_licences():
    first = (STATIC / "viewer.js").read_text(encoding="utf-8").split("\n", 1)[0]
    assert f"from sources sha256 {_sources_digest()}" in first, \
        "viewer/src or viewer/package-lock.json changed: rebuild the bundle (cd viewer && npm ci && npm run build)"
    lock = json.loads((ROOT / "viewer" / "package-lock.json").read_text())["packages"]
    licences = (STATIC / "viewer.LICENSES.txt").read_text(encoding="utf-8")
    for package in ("three", "@pixiv/three-vrm", "@pixiv/three-vrm-animation"):
        version = lock[f"node_modules/{package}"]["version"]
        assert f"{package}@{version} (MIT)" in first
        assert f"{package} {version} (MIT)" in licences
    assert licences.count("Permission is hereby granted, free of charge") >= 3
    assert not list((ROOT / "sgt_tui" / "view").rglob("node_modules"))

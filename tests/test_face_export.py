"""The face's exports read back: the Live Link Face CSV against the app's own format and Unreal's
importer's rules, the ARKit CSV/NPZ/JSON, the ARKit -> VRM expression mapping, the glTF's face
node and the .vrma's expression tracks (by their JSON), and `sgt export`'s face options. The
real clients (three.js, three-vrm-animation, the glTF validator, Blender) are in
tests/test_face_export_clients.py."""

from __future__ import annotations

import csv
import io
import json
import re
import struct

import numpy as np
import pytest

from core.face import (ARKIT_INDEX, ARKIT_NAMES, EXPRESSIONS, EYE_DOWN_LIMIT, EYE_UP_LIMIT, EYE_YAW_LIMIT,
                       FaceTrack, blendshapes, expression_weights, set_eye_looks)
from core.motion import MotionClip, MotionFile, Track
from core.skeleton import FPS, JOINT_INDEX, REST_POSE

#: The header row of a recording of Epic's Live Link Face app, typed out from the app's CSV
#: (the 52 blendshapes capitalised, in the app's order: JawRight before JawLeft, MouthRight
#: before MouthLeft; then the head's and eyes' angles).
APP_HEADER = (
    "Timecode,BlendShapeCount,EyeBlinkLeft,EyeLookDownLeft,EyeLookInLeft,EyeLookOutLeft,EyeLookUpLeft,"
    "EyeSquintLeft,EyeWideLeft,EyeBlinkRight,EyeLookDownRight,EyeLookInRight,EyeLookOutRight,EyeLookUpRight,"
    "EyeSquintRight,EyeWideRight,JawForward,JawRight,JawLeft,JawOpen,MouthClose,MouthFunnel,MouthPucker,"
    "MouthRight,MouthLeft,MouthSmileLeft,MouthSmileRight,MouthFrownLeft,MouthFrownRight,MouthDimpleLeft,"
    "MouthDimpleRight,MouthStretchLeft,MouthStretchRight,MouthRollLower,MouthRollUpper,MouthShrugLower,"
    "MouthShrugUpper,MouthPressLeft,MouthPressRight,MouthLowerDownLeft,MouthLowerDownRight,MouthUpperUpLeft,"
    "MouthUpperUpRight,BrowDownLeft,BrowDownRight,BrowInnerUp,BrowOuterUpLeft,BrowOuterUpRight,CheekPuff,"
    "CheekSquintLeft,CheekSquintRight,NoseSneerLeft,NoseSneerRight,TongueOut,HeadYaw,HeadPitch,HeadRoll,"
    "LeftEyeYaw,LeftEyePitch,LeftEyeRoll,RightEyeYaw,RightEyePitch,RightEyeRoll"
)


def talking_face(n: int = 45, seed: int = 0) -> FaceTrack:
    """A face that talks: the jaw opening and closing (rounded now and then), both eyes blinking
    at frames 10-12 and the left one alone at 30, the gaze going from the right to the left and
    up, a smile in the middle, and a little of every other blendshape."""
    rng = np.random.default_rng(seed)
    w = rng.uniform(0.0, 0.05, (n, len(ARKIT_NAMES)))
    t = np.arange(n)
    w[:, ARKIT_INDEX["jawOpen"]] = 0.5 + 0.5 * np.sin(t / 2.0)
    w[:, ARKIT_INDEX["mouthFunnel"]] = np.where(t % 12 < 4, 0.6, 0.0)
    for side in ("Left", "Right"):
        w[10:13, ARKIT_INDEX["eyeBlink" + side]] = 1.0
        w[15:25, ARKIT_INDEX["mouthSmile" + side]] = 0.7
    w[30:31, ARKIT_INDEX["eyeBlinkLeft"]] = 1.0
    gaze = np.zeros((n, 2, 2))
    gaze[:, :, 0] = np.linspace(-0.9, 0.9, n)[:, None] * EYE_YAW_LIMIT  # 90 % of the eyes' reach
    gaze[:, :, 1] = np.linspace(0.0, 12.0, n)[:, None]
    set_eye_looks(w, gaze)
    return FaceTrack(w, gaze)


def face_clip(n: int = 45, face: FaceTrack | None = None, **kw) -> MotionClip:
    """A clip at rest with ``face`` (a talking one by default); the head turned 20 degrees to the
    character's left from frame 20 on."""
    clip = MotionClip(poses=np.tile(REST_POSE, (n, 1)), face=face if face is not None else talking_face(n), **kw)
    pos = clip.positions.copy()
    turn = np.radians(20.0)
    rot = np.array([[np.cos(turn), 0, np.sin(turn)], [0, 1, 0], [-np.sin(turn), 0, np.cos(turn)]])
    neck = pos[:, JOINT_INDEX["neck"]]
    for j in ("nose", "head_top"):
        pos[20:, JOINT_INDEX[j]] = neck[20:] + (pos[20:, JOINT_INDEX[j]] - neck[20:]) @ rot.T
    clip.positions = pos
    return clip


def _csv_rows(text: str) -> list[list[str]]:
    return list(csv.reader(io.StringIO(text)))


# -- Live Link Face CSV ------------------------------------------------------------------------

def test_livelink_csv_has_the_apps_header_and_rows_unreal_imports():
    from renders.face_export import livelink_csv

    clip = face_clip()
    text = livelink_csv(clip)
    rows = _csv_rows(text)
    assert ",".join(rows[0]) == APP_HEADER
    assert len(rows) == 1 + clip.n_frames and text.endswith("\n")
    # Unreal's LiveLinkFaceImporter: first two columns named so, every line as many values as
    # the header (it stops at the first line that has not), no empty field, a timecode of four
    # ':' fields whose last is frames at 60 fps.
    for i, row in enumerate(rows[1:]):
        assert len(row) == len(rows[0]) and all(row), i
        assert re.fullmatch(r"\d\d:\d\d:\d\d:\d\d\.\d\d\d", row[0]), row[0]
        assert row[1] == "61"
        h, m, s, f = row[0].split(":")
        seconds = int(h) * 3600 + int(m) * 60 + int(s) + float(f) / 60.0
        assert seconds == pytest.approx(i / FPS, abs=1e-9), row[0]


def test_livelink_timecodes_roll_over_seconds_minutes_hours():
    from renders.face_export import livelink_timecode

    assert livelink_timecode(0) == "00:00:00:00.000"
    assert livelink_timecode(1) == "00:00:00:04.000"
    assert livelink_timecode(14) == "00:00:00:56.000"
    assert livelink_timecode(15) == "00:00:01:00.000"
    assert livelink_timecode(15 * 60 + 7) == "00:01:00:28.000"
    assert livelink_timecode(15 * 3600 * 2 + 15 * 61 + 2) == "02:01:01:08.000"


def test_livelink_values_are_the_face_by_column_name_and_the_head_and_eyes_in_radians():
    from renders.face_export import livelink_csv

    clip = face_clip()
    rows = _csv_rows(livelink_csv(clip))
    header = rows[0]
    values = np.array([[float(v) for v in r[2:]] for r in rows[1:]])
    col = {name: k for k, name in enumerate(header[2:])}
    for name in ARKIT_NAMES:
        got = values[:, col[name[0].upper() + name[1:]]]
        np.testing.assert_allclose(got, clip.face.weight(name), atol=1e-6, err_msg=name)
    gaze = np.radians(clip.face.gaze)
    np.testing.assert_allclose(values[:, col["LeftEyeYaw"]], gaze[:, 0, 0], atol=1e-6)
    np.testing.assert_allclose(values[:, col["LeftEyePitch"]], gaze[:, 0, 1], atol=1e-6)
    np.testing.assert_allclose(values[:, col["RightEyeYaw"]], gaze[:, 1, 0], atol=1e-6)
    np.testing.assert_allclose(values[:, col["RightEyePitch"]], gaze[:, 1, 1], atol=1e-6)
    assert not np.any(values[:, col["LeftEyeRoll"]]) and not np.any(values[:, col["RightEyeRoll"]])
    # The head: still for 20 frames, then turned 20 degrees to the character's left (yaw +).
    yaw, pitch, roll = (values[:, col[n]] for n in ("HeadYaw", "HeadPitch", "HeadRoll"))
    np.testing.assert_allclose(yaw[:20], 0.0, atol=1e-6)
    np.testing.assert_allclose(yaw[20:], np.radians(20.0), atol=1e-5)
    np.testing.assert_allclose(pitch, 0.0, atol=1e-5)
    np.testing.assert_allclose(roll, 0.0, atol=1e-5)


def test_head_angles_signs_pitch_up_and_roll_to_the_right_shoulder():
    from renders.face_export import head_angles

    clip = face_clip(2)
    pos = clip.positions.copy()
    neck = pos[1, JOINT_INDEX["neck"]]

    def turned(rot):
        p = pos[1].copy()
        for j in ("nose", "head_top"):
            p[JOINT_INDEX[j]] = neck + (pos[1, JOINT_INDEX[j]] - neck) @ rot.T
        return p

    a = np.radians(15.0)
    up = np.array([[1, 0, 0], [0, np.cos(a), np.sin(a)], [0, -np.sin(a), np.cos(a)]])  # face (+z) towards +y
    to_right = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])  # top towards -x
    got = head_angles(np.stack([turned(up), turned(to_right)]))
    np.testing.assert_allclose(got[0], [0.0, a, 0.0], atol=1e-5)
    np.testing.assert_allclose(got[1], [0.0, 0.0, a], atol=1e-5)


# -- ARKit CSV, NPZ, JSON ----------------------------------------------------------------------

def test_arkit_csv_npz_json_hold_the_weights_gaze_and_utterances():
    from renders.face_export import arkit_csv, arkit_json_bytes, arkit_npz_bytes

    clip = face_clip(speaker="guide")
    frames = [0] * 20 + [None] * 5 + [3] * 20
    rows = _csv_rows(arkit_csv(clip, frames))
    assert rows[0] == ["frame", "time", "utterance", *ARKIT_NAMES, "leftEyeYaw", "leftEyePitch", "rightEyeYaw", "rightEyePitch"]
    body = rows[1:]
    assert [r[2] for r in body] == ["0"] * 20 + [""] * 5 + ["3"] * 20
    assert [float(r[1]) for r in body] == pytest.approx(np.arange(45) / FPS, abs=1e-6)
    np.testing.assert_allclose(np.array([[float(v) for v in r[3:55]] for r in body]), clip.face.weights, atol=6e-4)
    np.testing.assert_allclose(np.array([[float(v) for v in r[55:]] for r in body]), clip.face.gaze.reshape(45, 4), atol=6e-3)

    z = np.load(io.BytesIO(arkit_npz_bytes(clip, frames)))
    assert list(z["names"]) == list(ARKIT_NAMES) and list(z["eyes"]) == ["left", "right"] and int(z["fps"]) == FPS
    np.testing.assert_array_equal(z["weights"], clip.face.weights)
    np.testing.assert_array_equal(z["gaze"], clip.face.gaze)
    assert z["utterance"].tolist() == [0] * 20 + [-1] * 5 + [3] * 20
    np.testing.assert_allclose(z["time"], np.arange(45) / FPS, atol=1e-6)

    raw = arkit_json_bytes(clip, frames).decode()
    doc = json.loads(raw)
    assert (doc["format"], doc["version"], doc["fps"], doc["frames"], doc["speaker"]) == ("sgt-arkit", 1, FPS, 45, "guide")
    assert doc["names"] == list(ARKIT_NAMES) and doc["utterance"] == frames
    np.testing.assert_allclose(doc["weights"], clip.face.weights, atol=6e-4)
    np.testing.assert_allclose(doc["gaze"], clip.face.gaze, atol=6e-3)
    assert raw.count("\n") > 2 * 45  # a frame per line


def test_a_clip_without_a_face_is_refused():
    from renders.face_export import face_bytes

    clip = MotionClip(poses=np.tile(REST_POSE, (3, 1)))
    for kind, fmt in (("livelink", "csv"), ("arkit", "csv"), ("arkit", "npz"), ("arkit", "json")):
        with pytest.raises(ValueError, match="no face"):
            face_bytes(clip, kind, fmt, [None] * 3)


# -- ARKit -> VRM expressions ------------------------------------------------------------------

def _face_of(weights: np.ndarray, gaze=None) -> FaceTrack:
    weights = np.atleast_2d(weights)
    return FaceTrack(weights, np.zeros((len(weights), 2, 2)) if gaze is None else gaze)


def test_each_viseme_and_emotion_picture_maps_to_its_vrm_expression_alone():
    from model.face import VISEMES
    from renders.face_export import VRM_EMOTIONS, VRM_EXPRESSIONS, VRM_VISEMES, vrm_expressions

    pictures = {name: blendshapes(VISEMES[ours]) for name, ours in VRM_VISEMES.items()}
    pictures.update({vrm: expression_weights(ours) for vrm, ours in VRM_EMOTIONS.items()})
    for name, picture in pictures.items():
        got = vrm_expressions(_face_of(picture))
        assert list(got) == list(VRM_EXPRESSIONS)
        assert got[name][0] == pytest.approx(1.0, abs=0.02), (name, got)
        others = {k: float(v[0]) for k, v in got.items() if k != name and k not in ("blink", "blinkLeft", "blinkRight")}
        assert max(others.values()) < 0.03, (name, others)
    assert set(VRM_EMOTIONS.values()) <= set(EXPRESSIONS)


def test_half_a_viseme_with_a_smile_is_half_of_it_and_happy():
    from model.face import VISEMES
    from renders.face_export import vrm_expressions

    w = 0.5 * blendshapes(VISEMES["O"]) + expression_weights("happy")
    got = vrm_expressions(_face_of(w))
    assert got["oh"][0] == pytest.approx(0.5, abs=0.03) and got["happy"][0] == pytest.approx(1.0, abs=0.03)
    assert max(got[k][0] for k in ("aa", "ih", "ou", "ee", "angry", "sad", "surprised")) < 0.05


def test_blinks_split_into_both_eyes_and_each_eye_and_the_gaze_into_looks():
    from renders.face_export import vrm_expressions

    w = np.zeros((4, len(ARKIT_NAMES)))
    w[:, ARKIT_INDEX["eyeBlinkLeft"]] = [1.0, 1.0, 0.0, 0.3]
    w[:, ARKIT_INDEX["eyeBlinkRight"]] = [1.0, 0.2, 0.0, 0.3]
    yaw, up, down = EYE_YAW_LIMIT, EYE_UP_LIMIT, EYE_DOWN_LIMIT  # half the reach, or past it (a look of 1)
    gaze = np.array([[[yaw / 2, 0], [yaw / 2, 0]], [[-yaw - 5, 0], [-yaw - 5, 0]], [[0, up / 2], [0, up / 2]],
                     [[0, -down], [0, -down]]], float)
    got = vrm_expressions(_face_of(w, gaze))
    np.testing.assert_allclose(got["blink"], [1.0, 0.2, 0.0, 0.3], atol=1e-4)
    np.testing.assert_allclose(got["blinkLeft"], [0.0, 0.8, 0.0, 0.0], atol=1e-4)
    np.testing.assert_allclose(got["blinkRight"], 0.0, atol=1e-4)
    np.testing.assert_allclose(got["lookLeft"], [0.5, 0, 0, 0], atol=1e-4)
    np.testing.assert_allclose(got["lookRight"], [0, 1, 0, 0], atol=1e-4)
    np.testing.assert_allclose(got["lookUp"], [0, 0, 0.5, 0], atol=1e-4)
    np.testing.assert_allclose(got["lookDown"], [0, 0, 0, 1], atol=1e-4)


def test_gaze_from_the_eye_look_weights_undoes_set_eye_looks():
    from renders.face_rig import gaze_from_weights

    gaze = np.array([[[20, 10], [-12, -20]], [[-30, 20], [30, -25]], [[0, 0], [5, 3]]], float)
    w = np.zeros((3, len(ARKIT_NAMES)))
    set_eye_looks(w, gaze)
    np.testing.assert_allclose(gaze_from_weights(w), gaze, atol=1e-4)


# -- glTF: the face node and the .vrma's expressions (the files' JSON) ---------------------------

def glb_json(data: bytes) -> dict:
    magic, version, total = struct.unpack("<4sII", data[:12])
    assert magic == b"glTF" and version == 2 and total == len(data)
    n, kind = struct.unpack("<I4s", data[12:20])
    assert kind == b"JSON"
    return json.loads(data[20:20 + n])


def test_sgt_glb_has_a_face_with_52_arkit_targets_animated_by_weights():
    from renders.gltf import glb_bytes
    from renders.rigs import get_rig

    clip = face_clip()
    doc = glb_json(glb_bytes(clip, get_rig("sgt")))
    node = next(i for i, n in enumerate(doc["nodes"]) if n["name"] == "face")
    mesh = doc["meshes"][doc["nodes"][node]["mesh"]]
    assert mesh["extras"]["targetNames"] == list(ARKIT_NAMES) and mesh["weights"] == [0.0] * 52
    assert all(len(p["targets"]) == 52 for p in mesh["primitives"])
    assert node in doc["scenes"][0]["nodes"]
    paths = {c["target"]["path"]: c for c in doc["animations"][0]["channels"] if c["target"]["node"] == node}
    assert set(paths) == {"weights", "translation", "rotation"}
    sampler = doc["animations"][0]["samplers"][paths["weights"]["sampler"]]
    assert doc["accessors"][sampler["output"]]["count"] == 52 * clip.n_frames
    assert doc["accessors"][sampler["input"]]["count"] == clip.n_frames
    # every blendshape moves something
    for k, name in enumerate(ARKIT_NAMES):
        assert any(doc["accessors"][p["targets"][k]["POSITION"]]["max"] != [0.0, 0.0, 0.0]
                   or doc["accessors"][p["targets"][k]["POSITION"]]["min"] != [0.0, 0.0, 0.0]
                   for p in mesh["primitives"]), name


def test_no_face_node_without_a_face_or_for_other_rigs():
    from renders.gltf import glb_bytes
    from renders.rigs import get_rig

    plain = MotionClip(poses=np.tile(REST_POSE, (5, 1)))
    for clip, rig in ((plain, "sgt"), (face_clip(5), "mixamo"), (face_clip(5), "vrm"), (plain, "vrm")):
        doc = glb_json(glb_bytes(clip, get_rig(rig)))
        assert not any(n["name"] == "face" for n in doc["nodes"]), rig
        assert not any("targets" in p for m in doc.get("meshes", []) for p in m["primitives"]), rig
        if rig == "vrm" and clip is plain:
            assert "expressions" not in doc["extensions"]["VRMC_vrm_animation"]


def test_vrma_names_an_expression_node_per_preset_animated_by_translation():
    from renders.face_export import VRM_EXPRESSIONS
    from renders.gltf import glb_bytes
    from renders.rigs import get_rig

    clip = face_clip()
    doc = glb_json(glb_bytes(clip, get_rig("vrm")))
    ext = doc["extensions"]["VRMC_vrm_animation"]
    preset = ext["expressions"]["preset"]
    assert list(preset) == list(VRM_EXPRESSIONS) and "humanBones" in ext["humanoid"]
    channels = doc["animations"][0]["channels"]
    for name, ref in preset.items():
        node = ref["node"]
        assert doc["nodes"][node]["name"] == f"expression_{name}" and node in doc["scenes"][0]["nodes"]
        mine = [c for c in channels if c["target"]["node"] == node]
        assert [c["target"]["path"] for c in mine] == ["translation"], name


# -- sgt export --face ------------------------------------------------------------------------

def _take(n: int = 30) -> MotionFile:
    """Two speakers: guide speaks frames 0-14 (utterance 0), visitor 15-29 (utterance 1)."""
    clips, tracks = [], []
    for i, speaker in enumerate(("guide", "visitor")):
        face = talking_face(n, seed=i)
        clips.append(MotionClip(poses=np.tile(REST_POSE, (15, 1)), speaker=speaker, text=f"line {i}", index=i,
                                face=face.take(slice(15 * i, 15 * i + 15)), start=i * 1.0, audio_offset=0.2))
        tracks.append(Track(speaker=speaker, poses=np.tile(REST_POSE, (n, 1)), face=face))
    return MotionFile(clips, tracks, None)


@pytest.fixture
def fake_take(monkeypatch, tmp_path):
    """`sgt export` on a take with faces (until scripts generate them), read from a file that exists."""
    import sgt_tui.commands.clips as clips

    take = _take()
    monkeypatch.setattr(clips, "load_performance", lambda *a, **k: take)
    src = tmp_path / "take.json"
    src.write_text("{}")
    return take, src


def test_export_writes_a_live_link_csv_per_speaker_named_before_its_suffix(fake_take, tmp_path):
    from sgt_tui.cli import main

    take, src = fake_take
    assert main(["export", str(src), "-o", str(tmp_path / "out" / "talk.livelink.csv")]) == 0
    for track in take.tracks:
        rows = _csv_rows((tmp_path / "out" / f"talk.{track.speaker}.livelink.csv").read_text())
        assert ",".join(rows[0]) == APP_HEADER and len(rows) == 31
        jaw = [float(r[rows[0].index("JawOpen")]) for r in rows[1:]]
        np.testing.assert_allclose(jaw, track.face.weight("jawOpen"), atol=1e-6)
    timeline = json.loads((tmp_path / "out" / "talk.livelink.csv.timeline.json").read_text())
    assert timeline["files"] == {"guide": "talk.guide.livelink.csv", "visitor": "talk.visitor.livelink.csv"}
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "talk.guide.livelink.csv", "talk.livelink.csv.timeline.json", "talk.visitor.livelink.csv"]


@pytest.mark.parametrize("args, name, fmt", [
    (["-o", "x.arkit.npz"], "x.arkit.npz", "npz"),
    (["-o", "x.arkit.json"], "x.arkit.json", "json"),
    (["-o", "x.arkit.csv"], "x.arkit.csv", "csv"),
    (["-o", "plain.npz", "--face", "arkit"], "plain.npz", "npz"),
    (["-o", "plain.csv", "--face", "livelink"], "plain.csv", "livelink"),
])
def test_export_face_by_name_or_option_for_one_speaker(fake_take, tmp_path, monkeypatch, args, name, fmt):
    from sgt_tui.cli import main

    take, src = fake_take
    monkeypatch.chdir(tmp_path)
    assert main(["export", str(src), "--speaker", "visitor", *args]) == 0
    data = (tmp_path / name).read_bytes()
    face = take.tracks[1].face
    if fmt == "npz":
        np.testing.assert_array_equal(np.load(io.BytesIO(data))["weights"], face.weights)
    elif fmt == "json":
        doc = json.loads(data)
        np.testing.assert_allclose(doc["weights"], face.weights, atol=6e-4)
        assert doc["utterance"] == [None] * 15 + [1] * 15
    elif fmt == "csv":
        assert data.startswith(b"frame,time,utterance,eyeBlinkLeft,")
    else:
        assert data.decode().split("\n", 1)[0] == APP_HEADER


def test_export_face_to_standard_output_with_format(fake_take, capsys):
    from sgt_tui.cli import main

    _, src = fake_take
    assert main(["export", str(src), "--speaker", "guide", "-o", "-", "--face", "livelink", "--format", "csv"]) == 0
    assert capsys.readouterr().out.split("\n", 1)[0] == APP_HEADER


@pytest.mark.parametrize("args, status, message", [
    (["-o", "x.livelink.csv", "--rig", "vrm"], 2, "the same for every rig: drop --rig"),
    (["-o", "x.arkit.csv", "--face", "livelink"], 2, "is a arkit file"),
    (["-o", "x.bvh", "--face", "arkit"], 2, "writes .csv, .npz, .json, not .bvh"),
    (["-o", "x.livelink.json"], 2, "--face livelink writes .csv, not .json"),
])
def test_export_face_usage_errors(fake_take, tmp_path, capsys, args, status, message):
    from sgt_tui.cli import main

    _, src = fake_take
    args = [a if not a.startswith("x.") else str(tmp_path / a) for a in args]
    assert main(["export", str(src), *args]) == status
    assert message in capsys.readouterr().err
    assert not any(p.name.startswith("x") for p in tmp_path.iterdir())


def test_export_face_of_a_take_without_one_fails_before_writing(monkeypatch, tmp_path, capsys):
    import sgt_tui.commands.clips as clips
    from sgt_tui.cli import main

    take = _take()
    take.tracks[1].face = None
    monkeypatch.setattr(clips, "load_performance", lambda *a, **k: take)
    src = tmp_path / "take.json"
    src.write_text("{}")
    assert main(["export", str(src), "-o", str(tmp_path / "t.livelink.csv")]) == 1
    assert "no face for visitor" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["take.json"]


def test_the_commands_face_kinds_are_the_writers():
    from renders.face_export import FACE_KINDS
    from sgt_tui.commands.export import FACE_KINDS as COMMAND_KINDS

    assert COMMAND_KINDS == FACE_KINDS


def test_a_vrm_glb_is_a_gltf_and_its_vrma_the_vrm_animation(fake_take, tmp_path, capsys):
    """`--rig vrm -o x.glb` writes a glTF of the VRM skeleton (no VRM Animation extension: a
    .glb name never holds .vrma bytes), and says the face is left out; `-o x.vrma` is the VRM
    Animation with the face's expression tracks."""
    from sgt_tui.cli import main

    assert main(["export", "--rig", "vrm", str(fake_take[1]), "-o", str(tmp_path / "g.glb"), "--speaker", "guide"]) == 0
    err = capsys.readouterr().err
    doc = glb_json((tmp_path / "g.glb").read_bytes())
    assert "VRMC_vrm_animation" not in doc.get("extensions", {}) and "VRMC_vrm_animation" not in doc.get("extensionsUsed", [])
    assert doc["animations"] and "hips" in {n["name"] for n in doc["nodes"]}
    (line,) = [line for line in err.splitlines() if line.startswith(f"wrote {tmp_path / 'g.glb'}:")]
    assert "; no face: a glTF of the vrm rig has none" in line and "-o x.vrma" in line
    assert main(["export", str(fake_take[1]), "-o", str(tmp_path / "g.vrma"), "--speaker", "guide"]) == 0
    doc = glb_json((tmp_path / "g.vrma").read_bytes())
    assert "VRMC_vrm_animation" in doc["extensionsUsed"] and doc["extensions"]["VRMC_vrm_animation"]["expressions"]

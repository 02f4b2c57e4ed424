"""Tests of the sgt-motion file format (json and npz)."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from core.controls import Control
from core.motion import VERSION, MotionClip, MotionFileError, Track, load_motion, load_motion_file, save_motion
from core.skeleton import (
    FPS,
    JOINTS,
    REST_POSE,
    mirror_pose,
    normalize_pose,
    positions_from_pose,
)
from core.words import TimedWord


def _clips():
    rng = np.random.default_rng(0)
    a = normalize_pose(REST_POSE + 0.3 * rng.standard_normal((12, 27)).astype(np.float32))
    b = normalize_pose(mirror_pose(a[:5]))
    return [
        MotionClip(poses=a, speaker="ann", text="hello there",
                   words=[TimedWord("hello", 0.0, 0.4), TimedWord("there", 0.4, 0.8)],
                   controls=[Control("pose", "wave", 3, 9, 1, 5, {"speed": 1, "flip": False})]),
        MotionClip(poses=b),
    ]


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_round_trip(tmp_path, suffix):
    path = tmp_path / f"m{suffix}"
    clips = _clips()
    save_motion(path, clips)
    back = load_motion(path)
    assert len(back) == 2
    for orig, got in zip(clips, back):
        assert got.fps == FPS
        assert got.poses.shape == orig.poses.shape
        assert np.allclose(got.poses, orig.poses, atol=1e-5)
        assert got.positions.shape == (len(orig.poses), 10, 3)
        assert np.allclose(got.positions, positions_from_pose(orig.poses), atol=1e-4)
        assert got.speaker == orig.speaker and got.text == orig.text
        assert got.words == orig.words and got.controls == orig.controls
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_json_layout(tmp_path):
    path = tmp_path / "m.json"
    save_motion(path, _clips())
    doc = json.loads(path.read_text())
    assert doc["format"] == "sgt-motion" and doc["version"] == VERSION and doc["fps"] == FPS
    assert doc["joints"] == list(JOINTS)
    assert len(doc["bones"]) == 9 and "faces +z" in doc["coordinates"]
    u = doc["utterances"][0]
    assert len(u["poses"][0]) == 27 and len(u["positions"][0]) == 10
    assert all(round(x, 5) == x for x in u["poses"][0])


def test_json_has_one_line_per_frame(tmp_path):
    """Each frame of every array is one line (readable diffs, and the C encoder writes it: a
    100-utterance script's file took 15 s with one number per line)."""
    path = tmp_path / "m.json"
    clips = _clips()
    save_motion(path, clips, tracks=[Track("ann", clips[0].poses)])
    lines = path.read_text().splitlines()
    for key, width in (("poses", 27), ("positions", 10), ("palm", 2), ("fingers", 2)):
        starts = [i for i, line in enumerate(lines) if line.strip() == f'"{key}": [']
        assert len(starts) == 3, key  # two utterances and the track
        for i in starts:
            frame = json.loads(lines[i + 1].rstrip(","))
            assert len(frame) == width, key
            assert lines[i + 1].startswith(" " * (len(lines[i]) - len(lines[i].lstrip()) + 1))
    doc = json.loads(path.read_text())
    assert len(doc["utterances"][0]["poses"]) == 12 and len(doc["tracks"][0]["poses"]) == 12


def test_npz_layout(tmp_path):
    path = tmp_path / "m.npz"
    save_motion(path, _clips())
    with np.load(path) as z:
        assert {"meta", "poses_0", "positions_0", "poses_1", "positions_1"} <= set(z.files)
        meta = json.loads(str(z["meta"]))
    assert meta["format"] == "sgt-motion" and meta["utterances"][0]["speaker"] == "ann"


@pytest.mark.parametrize("change,message", [({"version": VERSION + 1}, f"motion file version {VERSION + 1} is not supported"),
                                            ({"format": "bvh"}, "format is 'bvh', expected 'sgt-motion'"),
                                            ({"fps": 30}, "fps 30, expected 15")])
def test_refuses_other_formats(tmp_path, change, message):
    path = tmp_path / "m.json"
    save_motion(path, _clips())
    doc = json.loads(path.read_text())
    doc.update(change)
    path.write_text(json.dumps(doc))
    with pytest.raises(MotionFileError) as exc:
        load_motion(path)
    assert str(exc.value).startswith(f"{path}: {message}")


def test_refuses_bad_version_npz(tmp_path):
    path = tmp_path / "m.npz"
    meta = {"format": "sgt-motion", "version": 99, "fps": FPS, "joints": list(JOINTS),
            "utterances": []}
    np.savez(path, meta=np.array(json.dumps(meta)))
    with pytest.raises(MotionFileError, match="version 99"):
        load_motion(path)


def test_bad_files(tmp_path):
    with pytest.raises(MotionFileError, match="no such file"):
        load_motion(tmp_path / "none.json")
    (tmp_path / "junk.json").write_text("{not json")
    with pytest.raises(MotionFileError, match="JSON"):
        load_motion(tmp_path / "junk.json")
    with pytest.raises(MotionFileError, match="unknown motion file type"):
        save_motion(tmp_path / "m.bvh", _clips())
    with pytest.raises(MotionFileError):
        MotionClip(poses=np.zeros((4, 26)))


def test_save_is_atomic_on_error(tmp_path):
    path = tmp_path / "m.json"
    save_motion(path, _clips())
    before = path.read_bytes()
    bad = _clips()
    bad[0].words = [TimedWord(object(), 0.0, 0.4)]  # not JSON-serialisable
    with pytest.raises(TypeError):
        save_motion(path, bad)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json"]


def test_atomic_write_keeps_usual_permissions(tmp_path):
    """A new file gets 0o666 less the umask (not mkstemp's 0o600); a replaced file keeps its mode."""
    import os
    import stat

    from core.fileio import atomic_write

    old = os.umask(0o022)
    try:
        new = tmp_path / "new.txt"
        atomic_write(new, b"x")
        assert stat.S_IMODE(new.stat().st_mode) == 0o644
        kept = tmp_path / "script.sgt"
        kept.write_text("a")
        kept.chmod(0o640)
        atomic_write(kept, b"b")
        assert stat.S_IMODE(kept.stat().st_mode) == 0o640 and kept.read_bytes() == b"b"
    finally:
        os.umask(old)


def _with_hands():
    from core.hands import HandTrack

    clip = _clips()[0]
    n = clip.n_frames
    hands = HandTrack.constant(n, ("relaxed", "point"), ("in", "down")).blend(
        HandTrack.constant(n, ("fist", "ok"), ("up", "forward")), np.linspace(0, 1, n))
    return MotionClip(poses=clip.poses, hands=hands, text="hands")


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_hands_round_trip(tmp_path, suffix):
    path = tmp_path / f"m{suffix}"
    clip = _with_hands()
    save_motion(path, [clip])
    back = load_motion(path)[0]
    np.testing.assert_allclose(back.hands.palm, clip.hands.palm, atol=1e-4)
    np.testing.assert_allclose(back.hands.fingers, clip.hands.fingers, atol=1e-2)


def test_version_1_files_load_with_relaxed_hands(tmp_path):
    from core.hands import HandTrack

    path = tmp_path / "old.json"
    save_motion(path, [_with_hands()])
    doc = json.loads(path.read_text())
    doc["version"] = 1
    del doc["hands"]
    for u in doc["utterances"]:
        del u["hands"]
    path.write_text(json.dumps(doc))
    back = load_motion(path)[0]
    rest = HandTrack.rest(back.n_frames)
    np.testing.assert_allclose(back.hands.fingers, rest.fingers)
    np.testing.assert_allclose(back.hands.palm, rest.palm)


@pytest.mark.parametrize("hands, message", [({"palm": [[[1, 0, 0]]], "fingers": []}, "palm must be"),
                                            ([1, 2], "hands must be an object"),
                                            ({"palm": [[[0, 0, 0], [0, 0, 0]]] * 12,
                                              "fingers": np.zeros((12, 2, 5, 4)).tolist()}, "zero length")])
def test_bad_hands_are_file_errors(tmp_path, hands, message):
    path = tmp_path / "m.json"
    save_motion(path, [_with_hands()])
    doc = json.loads(path.read_text())
    doc["utterances"][0]["hands"] = hands
    path.write_text(json.dumps(doc))
    with pytest.raises(MotionFileError, match=message):
        load_motion(path)


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_performance_clock_and_tracks_round_trip(tmp_path, suffix):
    a, b = _clips()
    a.index, a.start, a.audio_offset = 0, 0.0, 0.2
    b.index, b.start, b.audio_offset = 3, 14 / FPS, 0.0  # after a gap of 2 frames
    rng = np.random.default_rng(1)
    tracks = [Track(s, normalize_pose(REST_POSE + 0.1 * rng.standard_normal((19, 27)).astype(np.float32)))
              for s in ("ann", None)]
    script = tmp_path / "take.sgt"
    path = tmp_path / "out" / f"m{suffix}"
    path.parent.mkdir()
    save_motion(path, [a, b], tracks=tracks, source=script)
    got = load_motion_file(path)
    assert got.version == VERSION and got.source == os.path.normpath(path.parent / "../take.sgt")
    assert [(c.index, c.start, c.audio_offset, c.start_frame) for c in got.clips] == [(0, 0.0, 0.2, 0), (3, 14 / FPS, 0.0, 14)]
    assert [t.speaker for t in got.tracks] == ["ann", None]
    for orig, back in zip(tracks, got.tracks):
        assert np.allclose(back.poses, orig.poses, atol=1e-5)
        assert np.allclose(back.positions, positions_from_pose(orig.poses), atol=1e-4)
    if suffix == ".json":
        doc = json.loads(path.read_text())
        assert doc["source"] == "../take.sgt"  # relative to the motion file's folder
        assert doc["frames"] == 19 and doc["utterances"][1]["start"] == round(14 / FPS, 6)
        assert doc["utterances"][0]["audio_offset"] == 0.2 and len(doc["tracks"][0]["poses"]) == 19


def test_version_1_files_still_load(tmp_path):
    path = tmp_path / "old.json"
    save_motion(path, _clips())
    doc = json.loads(path.read_text())
    doc["version"] = 1
    for key in ("frames", "source", "tracks"):
        del doc[key]
    for u in doc["utterances"]:
        for key in ("index", "start", "audio_offset"):
            del u[key]
    path.write_text(json.dumps(doc))
    got = load_motion_file(path)
    assert got.version == 1 and got.tracks == [] and got.source is None
    # before the clock, utterances were one after another; their audio offsets are unknown
    assert [(c.index, c.start_frame, c.audio_offset) for c in got.clips] == [(0, 0, None), (1, 12, None)]


def test_a_track_or_an_utterance_outside_the_performance_is_refused(tmp_path):
    a, b = _clips()
    b.start = 20 / FPS
    path = tmp_path / "m.json"
    save_motion(path, [a, b], tracks=[Track("ann", a.poses)])
    doc = json.loads(path.read_text())
    assert doc["frames"] == 25
    doc["frames"] = 24
    path.write_text(json.dumps(doc))
    with pytest.raises(MotionFileError, match="utterance 2 .* does not fit in the performance's 24 frames"):
        load_motion_file(path)
    doc["frames"] = 25
    path.write_text(json.dumps(doc))
    with pytest.raises(MotionFileError, match=r"track 0: poses have shape \(12, 27\), expected \(25, 27\)"):
        load_motion_file(path)


@pytest.mark.parametrize("decimals", [0, 2, 4, 5])
def test_frame_text_reads_back_as_numpy_rounds(decimals):
    """The numpy writer of frame lines gives the numbers of ``np.round`` (signs, zeros, whole
    parts of several widths), aligned in columns."""
    from core.frames_text import frame_lines

    rng = np.random.default_rng(decimals)
    for scale in (1e-4, 1.0, 37.0, 900.0, 1e5):
        x = rng.standard_normal((40, 3, 2)) * scale
        x[0, 0] = (-0.0, -1e-9)
        x[1, 0] = (-(10.0 ** -decimals) * 0.6, 10.0 ** -decimals * 0.4)
        lines = frame_lines(x, decimals)
        if np.abs(np.round(x, decimals)).max() >= 1e4:  # five digits before the point: left to json
            assert lines is None
            continue
        assert len(lines) == 40 and len({len(line) for line in lines}) == 1
        assert np.array_equal(np.array([json.loads(line) for line in lines]), np.round(x, decimals))
    assert frame_lines(np.array([[np.nan]]), 2) is None and frame_lines(np.zeros((0, 3)), 2) is None

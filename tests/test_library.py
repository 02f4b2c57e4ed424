"""Tests of the motion library: built-in gestures, transforms, overrides, validation."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pytest

from core.skeleton import (
    JOINT_INDEX,
    N_BONES,
    REST_POSE,
    frame_count,
    mirror_pose,
    positions_from_pose,
)
from library import BUILTIN_DIR, Clip, Gesture, LibraryProblem, load_library

REQUIRED = """point_left point_right point_front point_up point_down point_self beat_right beat_left
beat_both wave nod head_shake shrug stop thumbs_up open_arms frame cup sweep big small count_one
count_two count_three progressive dismiss calm_down chop think""".split()


@pytest.fixture(autouse=True)
def _isolate_config(tmp_path, monkeypatch):
    """No user config leaks into the tests."""
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.delenv("XDG_CONFIG_HOME", raising=False)
    monkeypatch.delenv("SGT_LIBRARY_PATH", raising=False)
    monkeypatch.chdir(tmp_path)


@pytest.fixture(scope="module")
def lib():
    return load_library(use_config=False)


def _angles(poses):
    p = poses.reshape(len(poses), N_BONES, 3).astype(np.float64)
    cos = np.clip(np.sum(p[1:] * p[:-1], axis=-1), -1, 1)
    return np.degrees(np.arccos(cos))


def test_builtins_load_cleanly(lib):
    assert lib.problems == []
    assert len(lib.names()) >= 36
    assert lib.names() == sorted(lib.names())
    missing = [n for n in REQUIRED if lib.get(n) is None]
    assert missing == []
    for g in lib:
        assert isinstance(g, Gesture)
        assert g.origin == "built-in" and g.overrides is None
        assert 0.6 <= g.duration <= 2.0, g.name
        assert g.description and g.tags, g.name
        assert sum(k.stroke for k in g.keyframes) == 1, g.name


def test_unknown_name(lib):
    assert lib.get("no_such_gesture") is None
    assert lib.suggest("point_rigth") == "point_right"


@pytest.mark.parametrize("speed", [1, 2, 3])
def test_clips_are_smooth_unit_vectors(lib, speed):
    for g in lib:
        clip = g.clip(speed=speed)
        assert isinstance(clip, Clip)
        assert clip.poses.dtype == np.float32 and clip.poses.shape[1] == 27
        norms = np.linalg.norm(clip.poses.reshape(-1, N_BONES, 3), axis=-1)
        assert np.allclose(norms, 1.0, atol=1e-4), g.name
        # 50 degrees per frame at x1 (750 deg/s) is already a very fast gesture.
        assert _angles(clip.poses).max() < 50 * speed, g.name
        assert clip.stroke_frame is not None and 0 <= clip.stroke_frame < len(clip.poses)


@pytest.mark.parametrize("hold", [0.0, 0.05, 0.5, 1.234, 10.0])
def test_clip_length_without_building_the_clip(lib, hold):
    for g in lib:
        for speed in (1, 2, 3):
            assert g.clip_length(speed=speed, hold=hold) == len(g.clip(speed=speed, hold=hold).poses), (g.name, speed)


def test_starts_and_ends_near_rest(lib):
    rest = REST_POSE
    for g in lib:
        p = g.clip().poses
        for end in (p[0], p[-1]):
            assert _angles(np.stack([end, rest])).max() < 1.0, g.name


@pytest.mark.parametrize("speed", [2, 3])
def test_speed_divides_length(lib, speed):
    for g in lib:
        n1 = len(g.clip().poses)
        ns = len(g.clip(speed=speed).poses)
        assert abs(ns - n1 / speed) <= 1, (g.name, n1, ns)
        assert ns == frame_count(g.duration / speed)
        s1, ss = g.clip().stroke_frame, g.clip(speed=speed).stroke_frame
        assert abs(ss - s1 / speed) <= 1, g.name


def test_flip_and_mirror(lib):
    for g in lib:
        p = g.clip().poses
        f = g.clip(flip=True).poses
        assert np.allclose(f, mirror_pose(p))
        assert np.allclose(mirror_pose(mirror_pose(p)), p)
    # flipping a right-hand gesture moves the left hand instead
    p = lib.get("point_right").clip(flip=True).poses
    pos = positions_from_pose(p[lib.get("point_right").clip().stroke_frame])
    assert pos[JOINT_INDEX["left_wrist"], 0] > 0.4


@pytest.mark.parametrize("hold", [0.0, 0.2, 0.5, 1.0])
def test_hold_keeps_the_stroke_pose(lib, hold):
    g = lib.get("stop")
    base = g.clip()
    s = base.stroke_frame
    assert s is not None
    held = g.clip(hold=hold)
    extra = frame_count(hold) if hold > 0 else 0
    assert len(held.poses) == len(base.poses) + extra
    assert np.allclose(held.poses[s : s + extra + 1], base.poses[s])  # the stroke pose is held
    assert np.allclose(held.poses[s + extra + 1 :], base.poses[s + 1 :])  # then the retraction
    assert held.stroke_frame == s


def test_hold_without_stroke_keeps_the_final_pose(tmp_path):
    user = tmp_path / "u"
    user.mkdir()
    (user / "reach.toml").write_text(
        'name = "reach"\ndescription = "d"\ntags = []\nduration = 0.6\n'
        '[[keyframes]]\ntime = 0.0\n[[keyframes]]\ntime = 0.6\nright_elbow = [-1.0, 0.0, 0.0]\n'
    )
    g = load_library([user], use_config=False).get("reach")
    base = g.clip().poses
    held = g.clip(hold=0.4).poses
    assert len(held) == len(base) + frame_count(0.4)
    assert np.allclose(held[len(base) - 1 :], base[-1])


def test_bad_transform_arguments(lib):
    with pytest.raises(ValueError):
        lib.get("nod").clip(speed=0)
    with pytest.raises(ValueError):
        lib.get("nod").clip(hold=-1)


def _stroke_positions(lib, name):
    clip = lib.get(name).clip()
    return positions_from_pose(clip.poses[clip.stroke_frame])


def test_pointing_sides(lib):
    spine = JOINT_INDEX["spine"]
    rw = JOINT_INDEX["right_wrist"]
    right = _stroke_positions(lib, "point_right")
    left = _stroke_positions(lib, "point_left")
    assert right[rw, 0] - right[spine, 0] < -0.3
    assert left[rw, 0] - left[spine, 0] > 0.0
    up = _stroke_positions(lib, "point_up")
    assert up[rw, 1] > up[JOINT_INDEX["head_top"], 1]
    front = _stroke_positions(lib, "point_front")
    assert front[rw, 2] > 0.4


def test_hands_never_behind_or_through_the_body(lib):
    for g in lib:
        pos = positions_from_pose(g.clip().poses)
        for j in ("right_wrist", "left_wrist", "right_elbow", "left_elbow"):
            x, y, z = pos[:, JOINT_INDEX[j]].T
            assert (z > -0.1).all(), (g.name, j)
            inside = (np.abs(x) < 0.12) & (y > 0.95) & (y < 1.42)
            assert (z[inside] > 0.05).all(), (g.name, j)


def test_head_gestures_move_the_head(lib):
    nose = JOINT_INDEX["nose"]
    for name, axis in (("nod", 1), ("head_shake", 0)):
        pos = positions_from_pose(lib.get(name).clip().poses)
        assert np.ptp(pos[:, nose, axis]) > 0.03, name


# ---------------------------------------------------------------- user folders

SPEC = """name = "{name}"
description = "test gesture"
tags = ["test"]
duration = 1.0

[[keyframes]]
time = 0.0

[[keyframes]]
time = 0.5
stroke = true
right_elbow = [-1, 0, 0]

[[keyframes]]
time = 1.0
right_elbow = "rest"
"""


def _write(folder: Path, name: str, text: str | None = None) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text(text if text is not None else SPEC.format(name=name))
    return path


def test_user_override_wins(tmp_path):
    user = tmp_path / "mine"
    path = _write(user, "wave")
    _write(user, "brand_new")
    lib = load_library([user], use_config=False)
    g = lib.get("wave")
    assert g.path == path and g.origin == str(user)
    assert g.overrides == BUILTIN_DIR / "wave.toml"
    assert lib.get("brand_new").overrides is None
    assert lib.get("nod").origin == "built-in"
    assert lib.problems == []


def test_later_folder_wins(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    _write(a, "mine")
    pb = _write(b, "mine")
    lib = load_library([a, b], use_config=False)
    assert lib.get("mine").path == pb
    assert lib.get("mine").overrides == a / "mine.toml"


def test_missing_folder_is_a_problem(tmp_path):
    lib = load_library([tmp_path / "nope"], use_config=False)
    assert len(lib.problems) == 1 and lib.problems[0].path == tmp_path / "nope"
    assert "does not exist" in lib.problems[0].message
    assert len(lib.names()) >= 36


def test_config_sources(tmp_path, monkeypatch):
    home_cfg = tmp_path / "home" / ".config" / "sgt"
    home_cfg.mkdir(parents=True)
    (home_cfg / "config.toml").write_text('[library]\npaths = ["g_home"]\n')
    _write(home_cfg / "g_home", "from_home")
    (tmp_path / "sgt.toml").write_text('[library]\npaths = ["g_proj"]\n')
    _write(tmp_path / "g_proj", "from_home")  # overrides the home one
    _write(tmp_path / "g_env", "from_env")
    monkeypatch.setenv("SGT_LIBRARY_PATH", str(tmp_path / "g_env"))
    lib = load_library()
    assert lib.problems == []
    assert lib.get("from_home").path == tmp_path / "g_proj" / "from_home.toml"
    assert lib.get("from_home").overrides == home_cfg / "g_home" / "from_home.toml"
    assert lib.get("from_env") is not None
    assert load_library(use_config=False).get("from_env") is None


def test_bad_config_is_a_problem(tmp_path):
    (tmp_path / "sgt.toml").write_text("[library\npaths = 3\n")
    lib = load_library()
    assert any(p.path.name == "sgt.toml" for p in lib.problems)
    assert len(lib.names()) >= 36


BAD_CASES = {
    "missing name": ('description = "x"\nduration = 1\n[[keyframes]]\ntime = 0\n', "name", "missing"),
    "missing duration": ('name = "{n}"\n[[keyframes]]\ntime = 0\n', "duration", "missing"),
    "bad name": ('name = "Bad-Name"\nduration = 1\n[[keyframes]]\ntime = 0\n', "name", "lower-case"),
    "name vs file": ('name = "other"\nduration = 1\n[[keyframes]]\ntime = 0\n', "name", "file name"),
    "unknown bone": ('name = "{n}"\nduration = 1\n[[keyframes]]\ntime = 0\nright_elbw = [1, 0, 0]\n',
                     "keyframes[0].right_elbw", "did you mean 'right_elbow'"),
    "two numbers": ('name = "{n}"\nduration = 1\n[[keyframes]]\ntime = 0\nright_elbow = [1, 0]\n',
                    "keyframes[0].right_elbow", "3 numbers"),
    "zero vector": ('name = "{n}"\nduration = 1\n[[keyframes]]\ntime = 0\nnose = [0, 0, 0]\n',
                    "keyframes[0].nose", "zero length"),
    "time outside": ('name = "{n}"\nduration = 1\n[[keyframes]]\ntime = 1.5\n', "keyframes[0].time", "outside"),
    "time order": ('name = "{n}"\nduration = 1\n[[keyframes]]\ntime = 0.5\n[[keyframes]]\ntime = 0.2\n',
                   "keyframes[1].time", "not after"),
    "two strokes": ('name = "{n}"\nduration = 1\n[[keyframes]]\ntime = 0\nstroke = true\n'
                    '[[keyframes]]\ntime = 1\nstroke = true\n', "keyframes[1].stroke", "second stroke"),
    "toml syntax": ('name = "{n}"\nduration = \n', "toml", "Invalid value"),
}
#: Where each problem is in its TOML text (line, col; 0 when a missing key is about the file).
BAD_PLACES = {
    "missing name": (0, 0), "missing duration": (0, 0), "bad name": (1, 1), "name vs file": (1, 1),
    "unknown bone": (5, 1), "two numbers": (5, 1), "zero vector": (5, 1), "time outside": (4, 1),
    "time order": (6, 1), "two strokes": (8, 1), "toml syntax": (2, 12),
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_malformed_spec_is_reported(tmp_path, case):
    text, field, words = BAD_CASES[case]
    user = tmp_path / "user"
    path = _write(user, "broken", text.replace("{n}", "broken"))
    _write(user, "fine")
    lib = load_library([user], use_config=False)
    assert lib.get("broken") is None
    assert lib.get("fine") is not None and len(lib.names()) >= 37
    assert len(lib.problems) == 1, lib.problems
    prob = lib.problems[0]
    assert isinstance(prob, LibraryProblem)
    assert prob.path == path and prob.field == field
    assert words in str(prob)
    assert str(path) in str(prob) and field in str(prob)
    assert (prob.line, prob.col) == BAD_PLACES[case]
    if case == "unknown bone":  # the did-you-mean is data, not only text
        assert prob.suggestions == ("right_elbow",) and "right_elbw'" in prob.message


def test_keyframe_bones_default_to_previous(tmp_path):
    user = tmp_path / "u"
    _write(user, "hold_arm", """name = "hold_arm"
duration = 1.0
[[keyframes]]
time = 0.0
right_elbow = [-1, 0, 0]
[[keyframes]]
time = 1.0
stroke = true
nose = [0, 0, 1]
""")
    g = load_library([user], use_config=False).get("hold_arm")
    p = g.clip().poses.reshape(-1, N_BONES, 3)
    assert np.allclose(p[:, 7], [-1, 0, 0], atol=1e-5)  # right_elbow kept all along
    assert np.allclose(p[-1, 1], [0, 0, 1], atol=1e-5)


def test_unchanged_files_are_not_read_again(tmp_path, monkeypatch):
    import library

    first = load_library(use_config=False)
    reads = []
    real = library.read_spec
    monkeypatch.setattr(library, "read_spec", lambda path: reads.append(path) or real(path))
    assert load_library(use_config=False).names() == first.names() and reads == []
    # an edited file is re-read
    user = tmp_path / "u"
    path = _write(user, "edit_me")
    assert load_library([user], use_config=False).get("edit_me").duration == 1.0
    assert reads == [path]
    path.write_text(SPEC.format(name="edit_me").replace("duration = 1.0", "duration = 1.50"))
    os.utime(path, ns=(time.time_ns(), time.time_ns() + 10**9))
    assert load_library([user], use_config=False).get("edit_me").duration == 1.5
    assert reads == [path, path]

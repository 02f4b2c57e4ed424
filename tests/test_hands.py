"""Hands: the shape vocabulary, hand keys in gesture specs, hand tracks and their geometry."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core.hands import (
    HAND_JOINTS,
    PALMS,
    SHAPE_ANGLES,
    SHAPES,
    SIDES,
    HandTrack,
    hand_frames,
    hand_positions,
    local_hand_joints,
    nearest_shape,
    palm_direction,
)
from core.skeleton import positions_from_pose
from library import load_library
from library.spec import SpecError, parse_spec_text, sample_hands

SPEC = """name = "h"
duration = 1.0

[[keyframes]]
time = 0.0

[[keyframes]]
time = 0.5
stroke = true
right_elbow = [-0.9, 0.2, 0.3]
right_hand = "point"
right_palm = "down"

[[keyframes]]
time = 0.75
label = "keeps the hand"
right_wrist = [-0.5, 0.5, 0.5]

[[keyframes]]
time = 1.0
right_hand = "relaxed"
right_palm = "up"
"""


def _spec(text: str = SPEC):
    return parse_spec_text(text, Path("h.toml"))


def test_vocabulary_is_the_agreed_one():
    assert SHAPES == ("relaxed", "open", "fist", "point", "thumb_up", "thumb_down", "ok", "pinch",
                      "count1", "count2", "count3", "count4", "count5")
    assert PALMS == ("down", "up", "in", "out", "forward", "back")
    assert set(SHAPE_ANGLES) == set(SHAPES)


def test_palm_names_per_side():
    # the character's left is +x: "in" (towards the midline) is +x for the right hand
    assert palm_direction("in", "right").tolist() == [1.0, 0.0, 0.0]
    assert palm_direction("in", "left").tolist() == [-1.0, 0.0, 0.0]
    assert palm_direction("out", "right").tolist() == [-1.0, 0.0, 0.0]
    assert palm_direction("forward", "left").tolist() == [0.0, 0.0, 1.0]


def test_spec_hand_keys_keep_their_value_until_changed():
    spec = _spec()
    assert spec.keyframes[1].hands == {"right_hand": "point", "right_palm": "down"}
    assert spec.keyframes[2].hands == {}
    r = SIDES.index("right")
    # keyframe 0: rest (relaxed, palm in); 1 and 2: point, palm down; 3: relaxed, palm up
    np.testing.assert_allclose(spec.key_fingers[0, r], SHAPE_ANGLES["relaxed"])
    np.testing.assert_allclose(spec.key_fingers[1, r], SHAPE_ANGLES["point"])
    np.testing.assert_allclose(spec.key_fingers[2, r], SHAPE_ANGLES["point"])
    np.testing.assert_allclose(spec.key_fingers[3, r], SHAPE_ANGLES["relaxed"])
    np.testing.assert_allclose(spec.key_palms[:, r], [[1, 0, 0], [0, -1, 0], [0, -1, 0], [0, 1, 0]])
    # the left hand is never named: rest all along
    np.testing.assert_allclose(spec.key_palms[:, 0], [[-1, 0, 0]] * 4)


def test_spec_hands_interpolate_and_ease():
    spec = _spec()
    track = sample_hands(spec, 21)  # a frame every 0.05 s
    r = SIDES.index("right")
    assert track.n_frames == 21
    # exact on the keyframes
    np.testing.assert_allclose(track.fingers[10, r], SHAPE_ANGLES["point"], atol=1e-4)
    np.testing.assert_allclose(track.palm[10, r], [0, -1, 0], atol=1e-6)
    np.testing.assert_allclose(track.palm[20, r], [0, 1, 0], atol=1e-6)
    # halfway between relaxed and point: the mean of the two (smoothstep(0.5) = 0.5)
    np.testing.assert_allclose(track.fingers[5, r], (SHAPE_ANGLES["relaxed"] + SHAPE_ANGLES["point"]) / 2, atol=1e-4)
    # down -> up passes "in" (+x for the right hand), never through zero
    np.testing.assert_allclose(track.palm[(15 + 20) // 2 + 0, r] @ [1, 0, 0], 1.0, atol=0.2)
    assert np.all(np.abs(np.linalg.norm(track.palm, axis=-1) - 1) < 1e-5)
    # eased: the first step after a keyframe is smaller than the middle one
    step = np.abs(np.diff(track.fingers[:, r], axis=0)).sum(axis=(-1, -2))
    assert step[0] < step[4] and step[9] < step[5]


@pytest.mark.parametrize(
    "line, field, message, suggestion",
    [
        ('right_hand = "pointt"', "right_hand", "unknown hand shape 'pointt'", ("point",)),
        ('left_palm = "dwn"', "left_palm", "unknown palm direction 'dwn'", ("down",)),
        ("right_hand = 3", "right_hand", "must be a hand shape name", ()),
        ('rigth_hand = "fist"', "rigth_hand", "unknown bone 'rigth_hand'", ("right_hand",)),
    ],
)
def test_bad_hand_keys_are_spec_errors(line, field, message, suggestion):
    text = SPEC.replace('right_hand = "point"', line)
    with pytest.raises(SpecError) as info:
        _spec(text)
    err = info.value
    assert err.field == f"keyframes[1].{field}"
    assert message in err.message
    assert err.suggestions == suggestion
    assert (err.line, err.col) == (text.splitlines().index(line) + 1, 1)


def test_flip_mirrors_hands():
    lib = load_library(use_config=False)
    spec_text = SPEC.replace('name = "h"', 'name = "h"')
    g = lib.get("point_right")
    spec = _spec(spec_text)
    object.__setattr__(g, "spec", spec)  # a gesture with the test's hands
    g._base.clear()
    plain, flipped = g.clip(), g.clip(flip=True)
    r, left = SIDES.index("right"), SIDES.index("left")
    np.testing.assert_allclose(flipped.hands.fingers[:, left], plain.hands.fingers[:, r])
    np.testing.assert_allclose(flipped.hands.palm[:, left, 0], -plain.hands.palm[:, r, 0])
    np.testing.assert_allclose(flipped.hands.palm[:, left, 1:], plain.hands.palm[:, r, 1:])
    # still "in" towards the midline at rest
    np.testing.assert_allclose(flipped.hands.palm[0, left], palm_direction("in", "left"), atol=1e-6)
    held = g.clip(hold=0.4)
    assert held.hands.n_frames == held.n_frames
    s = held.stroke_frame
    np.testing.assert_allclose(held.hands.fingers[s : s + 7, r], np.repeat(plain.hands.fingers[s : s + 1, r], 7, 0))


def test_track_round_trip_and_validation():
    t = HandTrack.constant(4, ("fist", "ok"), ("down", "forward"))
    back = HandTrack.from_dict(t.to_dict())
    np.testing.assert_allclose(back.palm, t.palm, atol=1e-4)
    np.testing.assert_allclose(back.fingers, t.fingers, atol=1e-2)
    assert [nearest_shape(f) for f in back.fingers[0]] == ["fist", "ok"]
    with pytest.raises(ValueError):
        HandTrack(np.zeros((3, 2, 3)), np.zeros((3, 2, 5, 4)))  # zero palms
    with pytest.raises(ValueError):
        HandTrack(np.ones((3, 2, 3)), np.zeros((2, 2, 5, 4)))


# -- geometry ---------------------------------------------------------------------------------


def _tips(shape):
    j = local_hand_joints(SHAPE_ANGLES[shape])
    return {d: j[HAND_JOINTS.index(f"{d}_tip")] for d in ("thumb", "index", "middle", "ring", "little")}


def _extended(shape):
    """Digits nearly straight (root to tip at least 97% of their length); the thumb also out
    to its side (x), away from the palm."""
    j = local_hand_joints(SHAPE_ANGLES[shape])
    out = set()
    for d, digit in enumerate(("thumb", "index", "middle", "ring", "little")):
        chain = j[4 * d : 4 * d + 4]
        straight = np.linalg.norm(chain[3] - chain[0]) / np.linalg.norm(np.diff(chain, axis=0), axis=1).sum()
        if straight > 0.97 and (digit != "thumb" or chain[3][0] > 0.08):
            out.add(digit)
    return out


@pytest.mark.parametrize(
    "shape, digits",
    [("open", {"thumb", "index", "middle", "ring", "little"}), ("fist", set()), ("point", {"index"}),
     ("thumb_up", {"thumb"}), ("count1", {"index"}), ("count2", {"index", "middle"}),
     ("count3", {"index", "middle", "ring"}), ("count4", {"index", "middle", "ring", "little"}),
     ("count5", {"thumb", "index", "middle", "ring", "little"}), ("ok", {"middle", "ring", "little"}),
     ("relaxed", set()), ("pinch", set())],
)
def test_shapes_extend_the_right_digits(shape, digits):
    assert _extended(shape) == digits


@pytest.mark.parametrize("shape", ["ok", "pinch"])
def test_ok_and_pinch_tips_touch(shape):
    tips = _tips(shape)
    assert np.linalg.norm(tips["thumb"] - tips["index"]) < 0.015


def test_curled_fingers_end_on_the_palm_side():
    tips = _tips("fist")
    for d in ("index", "middle", "ring", "little"):
        assert tips[d][2] > 0.01 and tips[d][1] < 0.1


def test_hand_frames_face_the_palm_target():
    # forearm straight forward: palm down and up are reached by turning alone
    fwd = np.array([0.0, 0.0, 1.0])
    for palm in ("down", "up", "in", "out"):
        f = hand_frames(fwd, palm_direction(palm, "right"), "right")
        np.testing.assert_allclose(f[:, 2], palm_direction(palm, "right"), atol=1e-9)
        np.testing.assert_allclose(f[:, 1], fwd, atol=1e-9)  # no wrist bend
    # palm "forward" on a forward forearm: the wrist bends up to its limit (a "stop" hand)
    f = hand_frames(fwd, palm_direction("forward", "right"), "right")
    assert np.degrees(np.arccos(f[:, 2] @ [0, 0, 1])) == pytest.approx(90 - 70, abs=1e-6)
    assert f[1, 1] > 0.9  # the fingers point up
    # a right hand, forearm forward, palm down: the thumb is towards the midline (+x)
    f = hand_frames(fwd, palm_direction("down", "right"), "right")
    assert f[0, 0] > 0.99
    f = hand_frames(fwd, palm_direction("down", "left"), "left")
    assert f[0, 0] < -0.99
    # thumbs up: palm in, thumb up; thumbs down: palm out, thumb down
    assert hand_frames(fwd, palm_direction("in", "right"), "right")[1, 0] > 0.99
    assert hand_frames(fwd, palm_direction("out", "right"), "right")[1, 0] < -0.99


def test_hand_positions_follow_the_wrist_and_mirror():
    lib = load_library(use_config=False)
    clip = lib.get("point_right").clip()
    pos = positions_from_pose(clip.poses)
    hp = hand_positions(pos, clip.hands)
    assert hp.shape == (clip.n_frames, 2, len(HAND_JOINTS), 3)
    # every hand joint within a hand's length of its wrist
    for s, side in enumerate(SIDES):
        wrist = pos[:, 3 * s + 6] if side == "left" else pos[:, 9]
        assert np.all(np.linalg.norm(hp[:, s] - wrist[:, None], axis=-1) < 0.22)
    flipped = lib.get("point_right").clip(flip=True)
    hf = hand_positions(positions_from_pose(flipped.poses), flipped.hands)
    mirrored = hp[:, ::-1].copy()
    mirrored[..., 0] *= -1
    np.testing.assert_allclose(hf, mirrored, atol=1e-4)

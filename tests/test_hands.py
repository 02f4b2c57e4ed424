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


# -- generated motion: model/hands.py ----------------------------------------------------------


def _right(track):
    return track.fingers[:, SIDES.index("right")]


def test_beat_hands_relaxed_at_rest_and_open_when_gesturing():
    from core.skeleton import REST_POSE
    from model.hands import MAX_OPEN, beat_hands

    rest = beat_hands(np.repeat(REST_POSE[None], 10, axis=0))
    np.testing.assert_allclose(rest.fingers, HandTrack.rest(10).fingers, atol=1e-5)
    np.testing.assert_allclose(rest.palm, HandTrack.rest(10).palm, atol=1e-5)
    lib = load_library(use_config=False)
    wave = lib.get("wave").clip().poses  # the right forearm raised
    hands = beat_hands(wave)
    r = SIDES.index("right")
    from core.hands import openness

    o = openness(hands.fingers[:, r])
    assert o.max() > openness(SHAPE_ANGLES["relaxed"]) + 0.1  # opens towards a flat hand
    # at most MAX_OPEN of the way from relaxed to open
    limit = openness(SHAPE_ANGLES["relaxed"] + MAX_OPEN * (SHAPE_ANGLES["open"] - SHAPE_ANGLES["relaxed"]))
    assert o.max() <= limit + 1e-6
    assert openness(hands.fingers[:, 0]).max() < openness(SHAPE_ANGLES["relaxed"]) + 0.02  # the left hangs


def test_gesture_hands_exact_where_masked_and_eased_around():
    from model.hands import HAND_RAMP, with_gestures

    n = 30
    base = HandTrack.rest(n)
    gest = HandTrack.constant(n, ("relaxed", "point"), ("in", "down"))
    mask = np.zeros(n)
    mask[10:20] = 1
    out = with_gestures(base, gest, mask)
    np.testing.assert_allclose(_right(out)[10:20], _right(gest)[10:20], atol=1e-4)
    np.testing.assert_allclose(_right(out)[: 10 - HAND_RAMP - 1], _right(base)[: 10 - HAND_RAMP - 1], atol=1e-4)
    np.testing.assert_allclose(_right(out)[20 + HAND_RAMP + 1 :], _right(base)[20 + HAND_RAMP + 1 :], atol=1e-4)
    index_mcp = _right(out)[:, 1, 1]
    ramp = index_mcp[10 - HAND_RAMP - 1 : 11]
    assert np.all(np.diff(ramp) <= 1e-6) and ramp[0] > ramp[-1]  # eases from relaxed (20) to straight (0)
    between = (ramp > ramp[-1] + 0.5) & (ramp < ramp[0] - 0.5)
    assert between.sum() >= HAND_RAMP - 1  # through the ramp, not a jump


def test_limit_speed_spreads_a_snap():
    from model.hands import MAX_FINGER_STEP, MAX_PALM_STEP, limit_speed

    snap = HandTrack.rest(12).take(np.arange(12))
    fist = HandTrack.constant(12, ("fist", "fist"), ("up", "up"))
    snap.fingers[6:] = fist.fingers[6:]
    snap.palm[6:] = fist.palm[6:]
    out = limit_speed(snap)
    assert np.abs(np.diff(out.fingers, axis=0)).max() <= MAX_FINGER_STEP + 1e-4
    turn = np.degrees(np.arccos(np.clip(np.sum(out.palm[1:] * out.palm[:-1], -1), -1, 1)))
    assert turn.max() <= MAX_PALM_STEP + 1e-3
    np.testing.assert_allclose(out.fingers[-1], fist.fingers[-1], atol=1e-4)  # it gets there
    np.testing.assert_allclose(out.palm[-1], fist.palm[-1], atol=1e-4)


@pytest.mark.parametrize("engine", ["keyframe", "rules"])
def test_generated_motion_has_the_pose_controls_hands(engine):
    from core.skeleton import FPS
    from model.generate import generate_clips

    clip = generate_clips(source="guide: Look [pose:point_right] there, and [pose:thumbs_up] great.",
                          engine=engine, timing="estimate")[0]
    assert clip.hands.n_frames == clip.n_frames
    lib = load_library(use_config=False)
    for control in clip.controls:
        g = lib.get(control.name)
        stroke = control.start_frame + g.stroke_frame()
        want = {"point_right": "point", "thumbs_up": "thumb_up"}[control.name]
        assert nearest_shape(clip.hands.fingers[stroke, SIDES.index("right")]) == want, (engine, control.name)
        assert nearest_shape(clip.hands.fingers[stroke, SIDES.index("left")]) != want
    # layered: these one-handed gestures set the right hand only; the left is the generator's
    if engine == "keyframe":  # (the rules engine adds its own triggered gestures' hands)
        from model.hands import motion_hands
        from model.performance import MIN_EASE

        left = SIDES.index("left")
        inner = slice(MIN_EASE, clip.n_frames - MIN_EASE)  # (its first and last frames ease from the listener's hands)
        np.testing.assert_allclose(clip.hands.fingers[inner, left], motion_hands(clip.poses).fingers[inner, left],
                                   atol=1e-3)
    # every frame's hands move within the speed limits
    from model.hands import MAX_FINGER_STEP

    assert np.abs(np.diff(clip.hands.fingers, axis=0)).max() <= MAX_FINGER_STEP + 1e-3
    assert clip.n_frames > 2 * FPS


def test_rules_engine_gives_its_triggered_gestures_hands():
    from core.words import TimedWord
    from model.teacher import teach

    words = [TimedWord("right", 0.6, 0.9), TimedWord("now", 0.9, 1.2)]
    rng_a, rng_b = np.random.default_rng(4), np.random.default_rng(4)
    layers: list = []
    poses = teach(words, 45, rng=rng_a, trigger_prob=1.0, hands_out=layers)
    # the hands change nothing else: same poses, same random stream (the corpus stays the same)
    np.testing.assert_array_equal(poses, teach(words, 45, rng=rng_b, trigger_prob=1.0))
    assert rng_a.random() == rng_b.random()
    (track, weight), = layers
    assert weight.max() == pytest.approx(1.0, abs=0.05)
    at = int(np.argmax(weight))
    shapes = {nearest_shape(track.fingers[at, s]) for s in range(2)}
    assert shapes & {"point", "thumb_up"}  # "right" triggers point_right/left or thumbs_up


def test_terminal_figure_marks_hand_shapes():
    from core.skeleton import positions_from_pose
    from renders.terminal import figure_points, stick_figure

    clip = load_library(use_config=False).get("wave").clip()
    pos = positions_from_pose(clip.poses[clip.stroke_frame : clip.stroke_frame + 1])

    def dots(shape):
        pts = figure_points(pos, HandTrack.constant(1, ("relaxed", shape), ("in", "forward")))
        assert pts.shape == (1, 50, 3)
        lines = stick_figure(pts[0], 40, 20)
        return lines, sum((ord(c) - 0x2800).bit_count() for line in lines for c in line)

    open_lines, open_dots = dots("open")
    fist_lines, fist_dots = dots("fist")
    _, point_dots = dots("point")
    assert open_dots > point_dots > fist_dots  # five fingers, one, none
    assert open_lines != fist_lines
    # without hands: the old figure, a blob at each wrist
    plain = stick_figure(pos[0], 40, 20)
    assert plain != fist_lines and len(plain) == 20


# -- hands that never flip (issue 22) ----------------------------------------------------------

def test_no_library_gesture_turns_a_hand_more_than_45_degrees_a_frame():
    """Every gesture at every speed, flipped too, as renders and exports draw its hands: no hand
    turns more than 45 degrees between frames relative to its forearm (tests/strokes.py's
    hand_turns). The end of wave, open_arms and stop turned a hand by up to 180 degrees in one
    frame while its palm target moved at most 30: the wrist sat at its bend limit on both."""
    from types import SimpleNamespace

    from strokes import MAX_HAND_TURN, hand_turns

    worst = []
    for g in load_library(use_config=False).gestures.values():
        for speed in (1, 2, 3):
            for flip in (False, True):
                c = g.clip(speed=speed, flip=flip)
                if c.n_frames > 1:
                    worst.append((float(hand_turns(SimpleNamespace(poses=c.poses, hands=c.hands)).max()), g.name, speed, flip))
    worst.sort()
    assert worst[-1][0] <= MAX_HAND_TURN, worst[-5:]
    assert len(worst) == 6 * len(load_library(use_config=False).names())


def test_steady_palms_turns_a_flipping_hand_at_a_bounded_speed_and_is_a_fixed_point():
    """A forearm swinging fast past a palm target that runs nearly along it (the end of a
    "stop"): per frame, hand_frames rolls the hand about the forearm by 73 degrees in a frame
    (nearer the target, hand_frames's neutral fallback takes over; farther, less); steady_palms makes it roll at most MAX_ROLL_STEP a frame (its wrist bent at most
    MAX_BEND_STEP further), and hand_frames of its palm targets gives exactly the hands it chose."""
    from strokes import _least_rotation

    from core.hands import MAX_BEND_STEP, MAX_ROLL_STEP, hand_frames, steady_palms
    from core.skeleton import BONE_INDEX, JOINT_INDEX, REST_POSE, positions_from_pose

    n = 4
    poses = np.repeat(REST_POSE[None], n, 0).reshape(n, 9, 3).copy()
    pitch = np.radians(np.linspace(60, -60, n))  # the forearm from 60 degrees up to 60 down, 40 a frame (600 deg/s)
    poses[:, BONE_INDEX["right_wrist"]] = np.stack([np.zeros(n), np.sin(pitch), np.cos(pitch)], -1)
    poses = poses.reshape(n, 27)
    side = np.radians(15.5)  # the target 15.5 degrees off the forearm's sweep: its part square to the forearm swings round
    target = np.array([np.sin(side), 0.0, np.cos(side)])
    track = HandTrack(np.repeat(np.stack([palm_direction("in", "left"), target])[None], n, 0).astype(np.float32),
                      HandTrack.rest(n).fingers)
    pos = positions_from_pose(poses)
    forearm = pos[:, JOINT_INDEX["right_wrist"]] - pos[:, JOINT_INDEX["right_elbow"]]
    upper = pos[:, JOINT_INDEX["right_elbow"]] - pos[:, JOINT_INDEX["right_shoulder"]]
    d = forearm / np.linalg.norm(forearm, axis=-1, keepdims=True)

    def roll_steps(palm):
        f = hand_frames(forearm, palm, "right", upper)
        r = f[..., 2] - np.sum(f[..., 2] * d, -1, keepdims=True) * d  # the palm square to the forearm
        r /= np.linalg.norm(r, axis=-1, keepdims=True)
        carried = np.einsum("tij,tj->ti", _least_rotation(d[:-1], d[1:]), r[:-1])  # by the forearm's swing
        return f, np.degrees(np.arccos(np.clip(np.sum(carried * r[1:], -1), -1, 1)))

    _, before = roll_steps(track.palm[:, 1])
    assert before.max() > 2.5 * MAX_ROLL_STEP  # the roll's jump this is about (73 degrees in a frame)
    steady = steady_palms(pos, track)
    frames, after = roll_steps(steady.palm[:, 1])
    assert after.max() <= MAX_ROLL_STEP + 1e-6, after
    np.testing.assert_allclose(steady.palm[:, 0], track.palm[:, 0])  # the left hand had nothing to steady
    # a fixed point: hand_frames of the targets it wrote are the hands it chose
    np.testing.assert_allclose(frames[..., 2], steady.palm[:, 1], atol=1e-5)
    np.testing.assert_allclose(steady_palms(pos, steady).palm, steady.palm, atol=1e-5)
    assert MAX_BEND_STEP <= 45

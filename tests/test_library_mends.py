"""Strokes that read at a glance: each mended gesture's stroke measured as the renders draw it.

The stroke frame goes the renders' way (`renders.library_sheet.stroke_views`): the clip's
pose through `core.skeleton.positions_from_pose`, the hands through `core.hands.hand_frames`
with the upper arm (as `hand_positions` places them), the finger angles named by
`core.hands.nearest_shape`. Each test fails on the gesture's spec before this mend (the old
figures are in the comments).
"""

from __future__ import annotations

import numpy as np
import pytest
from test_library import _isolate_config  # noqa: F401  (an autouse fixture: no user config leaks in)

from core.hands import SIDES, hand_frames, hand_positions, nearest_shape, openness
from core.skeleton import JOINT_INDEX, REST_POSE, positions_from_pose
from library import load_library

#: Chest height: the wrist level with the chest, from the shoulders' height down to 15 cm below
#: them (the middle of the chest). Lower is the belly, where give, offer and the thumbs read as
#: a hand dropped in front of the stomach (their wrists were 17-27 cm below the shoulders).
CHEST_BAND = 0.15


@pytest.fixture(scope="module")
def lib():
    return load_library(use_config=False)


class Stroke:
    """A gesture's stroke frame as drawn: joint positions, and per hand (``SIDES`` order) its
    frame (columns: thumb side, along the fingers, out of the palm) and shape name."""

    def __init__(self, lib, name: str) -> None:
        self.clip = clip = lib.get(name).clip()
        f = clip.stroke_frame
        self.pos = positions_from_pose(clip.poses[f : f + 1])[0]
        self.hands = hand_positions(self.pos[None], clip.hands.take(slice(f, f + 1)))[0]
        self.fingers = clip.hands.fingers[f]
        self.frames = [hand_frames(self.at(f"{side}_wrist") - self.at(f"{side}_elbow"),
                                   clip.hands.palm[f, s].astype(np.float64), side,
                                   self.at(f"{side}_elbow") - self.at(f"{side}_shoulder"))
                       for s, side in enumerate(SIDES)]

    def at(self, joint: str) -> np.ndarray:
        return self.pos[JOINT_INDEX[joint]].astype(np.float64)

    def palm(self, side: str) -> np.ndarray:
        """The direction out of the palm of hand ``side``."""
        return self.frames[SIDES.index(side)][:, 2]

    def shape(self, side: str) -> str:
        return nearest_shape(self.fingers[SIDES.index(side)])

    def below_shoulders(self, side: str) -> float:
        """How far (m) the wrist of ``side`` is below its shoulder."""
        return float(self.at(f"{side}_shoulder")[1] - self.at(f"{side}_wrist")[1])


def _out(side: str) -> float:
    """+1 along the character's left (+x), -1 along its right: away from the midline for ``side``."""
    return 1.0 if side == "left" else -1.0


REST = positions_from_pose(REST_POSE)


def test_shrug_lifts_both_shoulders_and_opens_level_forearms_palms_up(lib):
    s = Stroke(lib, "shrug")
    for side in SIDES:
        lift = s.at(f"{side}_shoulder")[1] - REST[JOINT_INDEX[f"{side}_shoulder"]][1]
        assert lift > 0.08, side  # a shrug you see (was 0.065)
        elbow, wrist = s.at(f"{side}_elbow"), s.at(f"{side}_wrist")
        forearm = (wrist - elbow) / np.linalg.norm(wrist - elbow)
        assert abs(forearm[1]) < 0.25, side  # the forearm held out level (was -0.40: hands dropped to the hips)
        assert (wrist[0] - elbow[0]) * _out(side) > 0.1, side  # out from the elbow, away from the body
        assert forearm[2] > 0.5, side  # and forward
        assert s.palm(side)[1] > 0.5, side  # palm up
        assert s.shape(side) == "open", side


def test_fist_pump_raises_the_fist_above_the_shoulder(lib):
    s = Stroke(lib, "fist_pump")
    wrist, elbow = s.at("right_wrist"), s.at("right_elbow")
    assert wrist[1] > s.at("right_shoulder")[1] + 0.15  # well above the shoulder (was 9 cm below it)
    assert (wrist - elbow)[1] / np.linalg.norm(wrist - elbow) > 0.8  # the forearm upright
    assert s.shape("right") == "fist"
    assert openness(s.fingers[SIDES.index("right")]) < 0.05


def test_calm_down_presses_both_palms_down_in_front_of_the_body(lib):
    s = Stroke(lib, "calm_down")
    keys = lib.get("calm_down").key_frames(1)
    prepare = positions_from_pose(s.clip.poses[keys[1]])
    for side in SIDES:
        wrist = s.at(f"{side}_wrist")
        assert s.palm(side)[1] < -0.8, side  # palm down
        assert s.shape(side) == "open", side
        assert wrist[2] > 0.35, side  # in front of the body (was 0.30)
        assert abs(wrist[0]) < 0.25, side  # before the torso, not beside the hips (was 0.30)
        assert s.below_shoulders(side) > 0.25, side  # below the chest
        assert wrist[1] > s.at("spine")[1], side  # above the waist
        # pressing: the stroke is lower than the preparation
        assert prepare[JOINT_INDEX[f"{side}_wrist"], 1] - wrist[1] > 0.08, side


def _thumb(s: Stroke, side: str) -> np.ndarray:
    """The unit direction of the thumb of hand ``side`` (its MCP joint to its tip)."""
    from core.hands import HAND_JOINTS

    hand = s.hands[SIDES.index(side)]
    v = hand[HAND_JOINTS.index("thumb_tip")] - hand[HAND_JOINTS.index("thumb_mcp")]
    return v / np.linalg.norm(v)


@pytest.mark.parametrize("name, sides", [("give", SIDES), ("offer", ("right",)), ("thumbs_up", ("right",)),
                                         ("thumbs_down", ("right",))])
def test_hands_held_at_chest_height(lib, name, sides):
    s = Stroke(lib, name)
    for side in sides:
        # give 0.27 m below the shoulders before, offer 0.18, thumbs up 0.17, thumbs down 0.22
        assert -0.05 < s.below_shoulders(side) < CHEST_BAND, (name, side, s.below_shoulders(side))
        assert s.at(f"{side}_wrist")[2] > 0.3, (name, side)  # held out in front
        if name == "thumbs_up":
            assert _thumb(s, side)[1] > 0.9
        elif name == "thumbs_down":
            assert _thumb(s, side)[1] < -0.8
        else:
            assert s.palm(side)[1] > 0.8, (name, side)  # palm up, presenting
            assert s.shape(side) == "open", (name, side)


def test_cross_arms_closes_both_hands(lib):
    s = Stroke(lib, "cross_arms")
    assert [s.shape(side) for side in SIDES] == ["fist", "fist"]  # were relaxed
    for side in SIDES:  # each hand on the other side of the midline: the arms cross
        assert s.at(f"{side}_wrist")[0] * _out(side) < 0, side
    end = lib.get("cross_arms").clip()
    assert [nearest_shape(f) for f in end.hands.fingers[-1]] == ["relaxed", "relaxed"]  # and open again


def test_reaches_to_the_listener_stand_clear_of_the_body_in_the_default_view(lib):
    """From the default camera (renders.mannequin.DEFAULT_VIEW), the right hand of a point, a
    handshake, an offer or a thumbs up at the listener is drawn beside the torso, not over it,
    at least 1.5 torso half-widths from its middle (from the camera above the front-right they
    were 1.0, 0.0 and 0.2: the handshake, the offer and the thumbs up were drawn in front of
    the belly, and the forearm dropped down the picture)."""
    from renders.mannequin import DEFAULT_VIEW, TORSO_HALF_WIDTH, VIEWS, project

    a = np.radians(VIEWS[DEFAULT_VIEW].azimuth)
    across = np.array([np.cos(a), 0.0, np.sin(a)])  # the picture's right, in the world
    # the torso's half-width as the camera sees it (an ellipse TORSO_HALF_WIDTH across)
    half = np.hypot(TORSO_HALF_WIDTH[0] * np.cos(a), TORSO_HALF_WIDTH[1] * np.sin(a))
    for name in ("point_front", "handshake", "offer", "thumbs_up"):
        s = Stroke(lib, name)
        hand = s.hands[SIDES.index("right")].mean(axis=0)
        middle = np.array([0.0, hand[1], 0.0])
        x_hand, x_mid, x_edge = (project(p, 400, 400, DEFAULT_VIEW)[0] for p in (hand, middle, middle + half * across))
        clear = abs(x_hand - x_mid) / abs(x_edge - x_mid)
        assert clear > 1.5, (name, clear)

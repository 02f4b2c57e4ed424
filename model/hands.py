"""Hands for generated motion: every engine makes the body (T, 27); these rules give it hands.

- :func:`beat_hands`: relaxed at rest; a forearm raised in front of the body (gesturing) opens
  its hand up to half way and turns the palm half way up (the palm-up open hand of a beat),
  and a fast-moving wrist (a beat's stroke) opens it a little more;
- on top, hands that gestures set: the ``rules`` engine's word-triggered library gestures,
  then the pose controls' gestures (their spec's hand keys), each eased in and out with its
  own weights;
- :func:`limit_speed`: finger joints turn at most :data:`MAX_FINGER_STEP` degrees a frame and
  palms :data:`MAX_PALM_STEP`, so a gesture cut short never snaps its hand.
"""

from __future__ import annotations

import numpy as np

from core import cancel
from core.hands import SIDES, HandTrack, slerp
from core.skeleton import FPS, JOINT_INDEX, positions_from_pose

#: The most a finger joint turns in one frame (degrees; 600 degrees/s at 15 fps).
MAX_FINGER_STEP = 40.0
#: The most a palm target turns in one frame (degrees; 450 degrees/s).
MAX_PALM_STEP = 30.0
#: Frames over which a pose control's hands ease in and out (as the body's blend).
HAND_RAMP = 4
#: How far beats open a hand (0 relaxed .. 1 open).
MAX_OPEN = 0.65


def _smooth(x: np.ndarray, sigma: float) -> np.ndarray:
    if len(x) < 2:
        return x
    r = int(3 * sigma) + 1
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()
    pad = np.pad(x, (r, r), mode="edge")
    return np.convolve(pad, k, mode="valid")


def beat_hands(poses: np.ndarray) -> HandTrack:
    """Hands for body motion ``poses`` (T, 27) alone (see the module's first rule)."""
    pos = positions_from_pose(poses)
    n = len(pos)
    rest = HandTrack.rest(n)
    opened = HandTrack.constant(n, ("open", "open"), ("up", "up"))
    palm, fingers = rest.palm.copy(), rest.fingers.copy()
    for s, side in enumerate(SIDES):
        wrist = pos[:, JOINT_INDEX[f"{side}_wrist"]]
        forearm = wrist - pos[:, JOINT_INDEX[f"{side}_elbow"]]
        forearm /= np.maximum(np.linalg.norm(forearm, axis=-1, keepdims=True), 1e-9)
        raised = np.clip((forearm[:, 1] + 0.6) / 0.6, 0.0, 1.0)  # 0 hanging (rest y = -0.75), 1 level
        speed = np.linalg.norm(np.diff(wrist, axis=0, prepend=wrist[:1]), axis=-1) * FPS  # m/s
        w = np.clip(_smooth(0.45 * raised + 0.2 * np.clip(speed / 1.5, 0.0, 1.0) * raised, 1.0), 0.0, MAX_OPEN)
        fingers[:, s] = rest.blend(opened, w, sides=(s,)).fingers[:, s]
        palm[:, s] = rest.blend(opened, w * (0.5 / MAX_OPEN), sides=(s,)).palm[:, s]  # at most half way up
    return HandTrack(palm, fingers)


def with_gestures(base: HandTrack, gestures: HandTrack, mask: np.ndarray, ramp: int = HAND_RAMP) -> HandTrack:
    """``base`` with the gestures' hands where ``mask`` (T,) is set, eased in and out over
    ``ramp`` frames around each masked span (smoothstep), exact on the masked frames. A mask
    (T, 2) applies per side (:data:`core.hands.SIDES`): a layered gesture sets only its hands."""
    m = np.clip(np.asarray(mask, dtype=np.float64), 0.0, 1.0)
    if m.ndim == 2:
        for s in range(m.shape[1]):
            base = _with_gestures(base, gestures, m[:, s], ramp, (s,))
        return base
    return _with_gestures(base, gestures, m, ramp, (0, 1))


def _with_gestures(base: HandTrack, gestures: HandTrack, m: np.ndarray, ramp: int, sides) -> HandTrack:
    if not m.any():
        return base
    w = m.copy()
    on = m > 0.5
    t = np.arange(len(m))
    if ramp > 0 and on.any():
        # the nearest masked frame before and after each frame (linear time and memory)
        big = 10 * len(m) + 10
        before = np.maximum.accumulate(np.where(on, t, -big))
        after = np.minimum.accumulate(np.where(on, t, 2 * big)[::-1])[::-1]
        near = np.where(t - before <= after - t, before, after)
        dist = np.abs(t - near)
        u = np.clip(1.0 - dist / (ramp + 1), 0.0, 1.0)
        w = np.maximum(w, u * u * (3 - 2 * u))
        # the gestures' hands next to a span: its first or last frame, held
        gestures = gestures.take(np.where(on, t, np.clip(near, 0, len(m) - 1)))
    return base.blend(gestures, w, sides=sides)


def limit_speed(track: HandTrack, max_finger: float = MAX_FINGER_STEP, max_palm: float = MAX_PALM_STEP) -> HandTrack:
    """``track`` with no finger angle changing more than ``max_finger`` degrees a frame and no
    palm target turning more than ``max_palm`` degrees (each frame chases the requested one)."""
    palm, fingers = track.palm.astype(np.float64).copy(), track.fingers.astype(np.float64).copy()
    for t in range(1, track.n_frames):
        if not t % cancel.EVERY:
            cancel.check()
        step = fingers[t] - fingers[t - 1]
        fingers[t] = fingers[t - 1] + np.clip(step, -max_finger, max_finger)
        for s in range(2):
            a, b = palm[t - 1, s], palm[t, s]
            angle = np.degrees(np.arccos(np.clip(a @ b, -1.0, 1.0)))
            if angle > max_palm:
                palm[t, s] = _turn(a, b, max_palm / angle, inward=1.0 if s == 1 else -1.0)
    return HandTrack(palm, fingers)


def _turn(a: np.ndarray, b: np.ndarray, fraction: float, inward: float) -> np.ndarray:
    return slerp(a[None], b[None], np.array([fraction]), inward=inward)[0]


def motion_hands(poses: np.ndarray, layers=()) -> HandTrack:
    """Hands for generated body motion: :func:`beat_hands`, then each ``(track, weight)`` of
    ``layers`` in order (gesture hands and their weights, (T,) in [0, 1]; a weight of 1 is
    exact there), then :func:`limit_speed`. (The performance then keeps each hand's roll about
    the forearm continuous on the speaker's track: :func:`core.hands.steady_palms`.)"""
    track = beat_hands(poses)
    for gestures, weight in layers:
        track = with_gestures(track, gestures, weight)
    return limit_speed(track)

"""Hands: the hand skeleton, the hand-shape vocabulary and per-frame hand tracks (numpy only).

The body pose stays the 27 numbers of :mod:`core.skeleton`; hands are a separate layer that
travels with it. A *hand track* holds, per frame and per side (``SIDES``: left, right):

- ``palm`` (T, 2, 3): the direction the palm should face, in the skeleton's coordinates (y up,
  the character faces +z, its left is +x). It is a target: :func:`hand_frames` turns the hand
  about the forearm (pronation/supination) so that the palm faces it as nearly as it can, and
  bends the wrist (flexion/extension, at most :data:`MAX_WRIST_BEND` degrees) for the rest;
- ``fingers`` (T, 2, 5, 4): four angles in degrees per digit (``DIGITS``). For the four
  fingers: spread (away from the middle finger), then the flexion of the knuckle (MCP), the
  middle joint (PIP) and the end joint (DIP); positive curls towards the palm. For the thumb:
  abduction (away from the index, in the palm's plane), opposition (towards the palm), then
  the flexion of its MCP and IP joints.

Shapes (:data:`SHAPES`) name finger angles; palm names (:data:`PALMS`) name palm directions
per side: "in" is towards the body's midline (+x for the right hand), "out" away from it,
"forward" towards the listener (+z), "back" towards the speaker. The rest hand is
``relaxed`` with the palm ``in`` (hanging arms, palms to the thighs).

Hand joints (:data:`HAND_JOINTS`, per side): the thumb's CMC, MCP, IP and tip, and every
finger's MCP (knuckle), PIP, DIP and tip; :func:`hand_positions` places them (metres) from the
body's positions, its forearm directions and the track.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.easing import smoothstep
from core.skeleton import JOINT_INDEX

SIDES: tuple[str, ...] = ("left", "right")
DIGITS: tuple[str, ...] = ("thumb", "index", "middle", "ring", "little")

#: The hand-shape vocabulary (spec keys ``right_hand`` / ``left_hand``).
SHAPES: tuple[str, ...] = (
    "relaxed", "open", "fist", "point", "thumb_up", "thumb_down", "ok", "pinch",
    "count1", "count2", "count3", "count4", "count5",
)
#: Palm directions (spec keys ``right_palm`` / ``left_palm``).
PALMS: tuple[str, ...] = ("down", "up", "in", "out", "forward", "back")
REST_SHAPE = "relaxed"
REST_PALM = "in"

#: The wrist bends at most this far (degrees) to turn the palm where the forearm cannot.
MAX_WRIST_BEND = 70.0

# Finger angle rows (spread, mcp, pip, dip); thumb rows (abduction, opposition, mcp, ip).
_STRAIGHT = (0.0, 0.0, 0.0, 0.0)
_CURLED = (0.0, 88.0, 100.0, 55.0)
_THUMB_TUCKED = (14.4, 9.6, 53.2, 51.8)  # tip on the curled middle finger (fitted)
_THUMB_FOLDED = (8.6, 0.0, 70.0, 80.0)  # across the palm (counting three and four; fitted)
_THUMB_OUT = (75.0, 0.0, 0.0, 0.0)  # straight, square to the hand (thumbs up)
_THUMB_RING = (24.5, 12.5, 37.1, 47.8)  # tip on the bent index's tip (ok, pinch; fitted)


def _shape(thumb, index, middle, ring, little) -> np.ndarray:
    return np.array([thumb, index, middle, ring, little], dtype=np.float32)


#: Shape name -> finger angles (5, 4) in degrees.
SHAPE_ANGLES: dict[str, np.ndarray] = {
    "relaxed": _shape((25.0, 20.0, 10.0, 10.0), (2.0, 20.0, 30.0, 15.0), (0.0, 25.0, 35.0, 18.0),
                      (2.0, 30.0, 40.0, 20.0), (4.0, 35.0, 42.0, 22.0)),
    "open": _shape((50.0, 0.0, 0.0, 0.0), (6.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0),
                   (6.0, 0.0, 0.0, 0.0), (12.0, 0.0, 0.0, 0.0)),
    "fist": _shape(_THUMB_TUCKED, _CURLED, _CURLED, _CURLED, _CURLED),
    "point": _shape(_THUMB_TUCKED, _STRAIGHT, _CURLED, _CURLED, _CURLED),
    "thumb_up": _shape(_THUMB_OUT, _CURLED, _CURLED, _CURLED, _CURLED),
    "thumb_down": _shape(_THUMB_OUT, _CURLED, _CURLED, _CURLED, _CURLED),
    # the thumb and index tips meet (a ring); the other fingers stay up, a little spread
    "ok": _shape(_THUMB_RING, (0.0, 48.0, 62.0, 40.0), (0.0, 5.0, 5.0, 0.0),
                 (6.0, 8.0, 8.0, 0.0), (14.0, 12.0, 10.0, 0.0)),
    # the thumb and index tips meet; the other fingers curled
    "pinch": _shape(_THUMB_RING, (0.0, 48.0, 62.0, 40.0), (0.0, 60.0, 80.0, 45.0),
                    (0.0, 70.0, 85.0, 45.0), (0.0, 75.0, 85.0, 45.0)),
    "count1": _shape(_THUMB_TUCKED, _STRAIGHT, _CURLED, _CURLED, _CURLED),
    "count2": _shape(_THUMB_TUCKED, (8.0, 0.0, 0.0, 0.0), (8.0, 0.0, 0.0, 0.0), _CURLED, _CURLED),
    "count3": _shape(_THUMB_FOLDED, (8.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), (8.0, 0.0, 0.0, 0.0), _CURLED),
    "count4": _shape(_THUMB_FOLDED, (8.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), (8.0, 0.0, 0.0, 0.0),
                     (16.0, 0.0, 0.0, 0.0)),
    "count5": _shape((55.0, 0.0, 0.0, 0.0), (8.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), (8.0, 0.0, 0.0, 0.0),
                     (16.0, 0.0, 0.0, 0.0)),
}
def palm_direction(name: str, side: str) -> np.ndarray:
    """The unit direction (3,) of palm name ``name`` for ``side`` ("left" or "right")."""
    inward = -1.0 if side == "left" else 1.0  # the left hand is on +x: its midline is -x
    table = {"down": (0.0, -1.0, 0.0), "up": (0.0, 1.0, 0.0), "in": (inward, 0.0, 0.0),
             "out": (-inward, 0.0, 0.0), "forward": (0.0, 0.0, 1.0), "back": (0.0, 0.0, -1.0)}
    return np.array(table[name], dtype=np.float64)


def openness(fingers: np.ndarray) -> np.ndarray:
    """How open a hand is, 0 (fist) .. 1 (flat), from finger angles (..., 5, 4): the mean
    flexion of the four fingers' joints against the fist's."""
    f = np.asarray(fingers, dtype=np.float64)[..., 1:, 1:]
    fist = SHAPE_ANGLES["fist"][1:, 1:].astype(np.float64)
    return np.clip(1.0 - f.sum(axis=(-1, -2)) / fist.sum(), 0.0, 1.0)


def nearest_shape(fingers: np.ndarray) -> str:
    """The shape name whose finger angles (5, 4) are closest to ``fingers`` (sum of |degrees|)."""
    f = np.asarray(fingers, dtype=np.float64)
    return min(SHAPES, key=lambda s: float(np.abs(SHAPE_ANGLES[s] - f).sum()))


def nearest_palm(palm: np.ndarray, side: str) -> str:
    """The palm name of ``side`` whose direction is closest to ``palm`` (3,)."""
    return max(PALMS, key=lambda n: float(palm_direction(n, side) @ np.asarray(palm, dtype=np.float64)))


# -- tracks -------------------------------------------------------------------------------------


@dataclass
class HandTrack:
    """Per-frame hands: ``palm`` (T, 2, 3) unit palm targets and ``fingers`` (T, 2, 5, 4)
    degrees, side order :data:`SIDES` (left, right)."""

    palm: np.ndarray
    fingers: np.ndarray

    def __post_init__(self):
        self.palm = np.asarray(self.palm, dtype=np.float32)
        self.fingers = np.asarray(self.fingers, dtype=np.float32)
        t = self.palm.shape[0] if self.palm.ndim else -1
        if self.palm.shape != (t, 2, 3) or self.fingers.shape != (t, 2, 5, 4):
            raise ValueError(f"hands: palm must be (T, 2, 3) and fingers (T, 2, 5, 4), got "
                             f"{self.palm.shape} and {self.fingers.shape}")
        if not (np.all(np.isfinite(self.palm)) and np.all(np.isfinite(self.fingers))):
            raise ValueError("hands: values must be finite")
        n = np.linalg.norm(self.palm, axis=-1, keepdims=True)
        if np.any(n < 1e-6):
            raise ValueError("hands: a palm direction has zero length")
        self.palm = (self.palm / n).astype(np.float32)

    @property
    def n_frames(self) -> int:
        return int(self.palm.shape[0])

    @classmethod
    def rest(cls, n_frames: int) -> HandTrack:
        """Relaxed hands, palms in, for ``n_frames`` frames."""
        return cls.constant(n_frames, (REST_SHAPE, REST_SHAPE), (REST_PALM, REST_PALM))

    @classmethod
    def constant(cls, n_frames: int, shapes: tuple[str, str], palms: tuple[str, str]) -> HandTrack:
        """One (left, right) shape and palm on every frame."""
        palm = np.stack([palm_direction(p, s) for p, s in zip(palms, SIDES)])
        fingers = np.stack([SHAPE_ANGLES[s] for s in shapes])
        return cls(np.repeat(palm[None], n_frames, axis=0), np.repeat(fingers[None], n_frames, axis=0))

    def take(self, index) -> HandTrack:
        """The frames ``index`` (a slice or an integer array)."""
        return HandTrack(self.palm[index], self.fingers[index])

    def mirrored(self) -> HandTrack:
        """Left and right swapped and x negated (as :func:`core.skeleton.mirror_pose`)."""
        palm = self.palm[:, ::-1].copy()
        palm[..., 0] = -palm[..., 0]
        return HandTrack(palm, self.fingers[:, ::-1].copy())

    def blend(self, other: HandTrack, weight, sides=(0, 1)) -> HandTrack:
        """This track moved towards ``other`` by ``weight`` (T,) in [0, 1] on ``sides``:
        palms along the great circle, finger angles linearly."""
        w = np.clip(np.asarray(weight, dtype=np.float64), 0.0, 1.0)
        palm, fingers = self.palm.astype(np.float64), self.fingers.astype(np.float64)
        for s in sides:
            palm[:, s] = slerp(palm[:, s], other.palm[:, s].astype(np.float64), w, inward=1.0 if s == 1 else -1.0)
            fingers[:, s] += (other.fingers[:, s] - fingers[:, s]) * w[:, None, None]
        return HandTrack(palm, fingers)

    #: Decimals kept in files: palm directions to 1e-4, finger angles to 0.01 degree.
    DECIMALS = {"palm": 4, "fingers": 2}

    def to_dict(self) -> dict:
        return {key: np.round(getattr(self, key).astype(np.float64), d).tolist() for key, d in self.DECIMALS.items()}

    @classmethod
    def from_dict(cls, d) -> HandTrack:
        if not isinstance(d, dict) or "palm" not in d or "fingers" not in d:
            raise ValueError("hands must be an object with 'palm' and 'fingers'")
        return cls(np.asarray(d["palm"], dtype=np.float32), np.asarray(d["fingers"], dtype=np.float32))


def concat(tracks) -> HandTrack:
    tracks = list(tracks)
    return HandTrack(np.concatenate([t.palm for t in tracks]), np.concatenate([t.fingers for t in tracks]))


def slerp(a: np.ndarray, b: np.ndarray, w, inward: float = 1.0) -> np.ndarray:
    """Unit vectors (..., 3) ``a`` turned towards ``b`` by fraction ``w`` (broadcast to (...)).
    A palm turning to its opposite goes through :func:`_halfway` (as a forearm turns it);
    ``inward`` is the sign of x towards the body's midline (+1 right hand, -1 left)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64) * np.ones(a.shape[:-1])
    opposite = np.sum(a * b, axis=-1) < -0.999
    if not np.any(opposite):
        return _slerp_plain(a, b, w)
    mid = _halfway(a, inward)
    via = np.where((w <= 0.5)[..., None], _slerp_plain(a, mid, np.minimum(2 * w, 1.0)),
                   _slerp_plain(mid, b, np.maximum(2 * w - 1.0, 0.0)))
    return np.where(opposite[..., None], via, _slerp_plain(a, b, w))


def _slerp_plain(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    c = np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)
    angle = np.arccos(c)
    s = np.sin(angle)
    small = s < 1e-6
    safe = np.where(small, 1.0, s)
    k0 = np.where(small, 1.0 - w, np.sin((1.0 - w) * angle) / safe)[..., None]
    k1 = np.where(small, w, np.sin(w * angle) / safe)[..., None]
    return _unit(k0 * a + k1 * b)


def _halfway(a: np.ndarray, inward: float) -> np.ndarray:
    """The direction a palm passes when it turns to its opposite: up/down and forward/back
    pass "in" (the thumb up), in/out pass "down"."""
    x_major = np.abs(a[..., 0]) > 0.7
    down = np.zeros_like(a)
    down[..., 1] = -1.0
    toward_midline = np.zeros_like(a)
    toward_midline[..., 0] = inward
    return _unit(_reject(np.where(x_major[..., None], down, toward_midline), a))


def interpolate_hands(times: np.ndarray, palms: np.ndarray, fingers: np.ndarray, ts: np.ndarray) -> HandTrack:
    """Hands at times ``ts`` from keyframes at ``times`` (K,): palm targets (K, 2, 3) and finger
    angles (K, 2, 5, 4). Between two keyframes each hand eases (smoothstep: still at every
    keyframe, never past it); palms turn along the great circle, through "in" (thumb up) when
    they turn to their opposite. Before the first keyframe and after the last, held."""
    times = np.asarray(times, dtype=np.float64)
    palms = np.asarray(palms, dtype=np.float64).copy()
    fingers = np.asarray(fingers, dtype=np.float64)
    ts = np.clip(np.asarray(ts, dtype=np.float64), times[0], times[-1])
    if len(times) == 1:
        seg = np.zeros(len(ts), dtype=int)
        u = np.zeros(len(ts))
        nxt = seg
    else:
        seg = np.clip(np.searchsorted(times, ts, side="right") - 1, 0, len(times) - 2)
        u = smoothstep((ts - times[seg]) / np.diff(times)[seg])
        nxt = seg + 1
    palm = np.stack([slerp(palms[seg, s], palms[nxt, s], u, inward=1.0 if side == "right" else -1.0)
                     for s, side in enumerate(SIDES)], axis=1)
    fing = fingers[seg] + (fingers[nxt] - fingers[seg]) * u[:, None, None, None]
    return HandTrack(palm, fing)


# -- geometry -----------------------------------------------------------------------------------

#: Per side, the hand's joints (names without the side prefix), parents before children.
HAND_JOINTS: tuple[str, ...] = tuple(
    f"{d}_{j}" for d in DIGITS for j in (("cmc", "mcp", "ip", "tip") if d == "thumb" else ("mcp", "pip", "dip", "tip"))
)

# Hand geometry in the hand's frame (metres): x to the thumb side, y along the fingers, z out
# of the palm. Roots of each digit (the thumb's CMC, the fingers' knuckles) and segment lengths.
_ROOTS = np.array([(0.022, 0.022, 0.012), (0.024, 0.088, 0.0), (0.004, 0.090, 0.0),
                   (-0.015, 0.085, 0.0), (-0.032, 0.077, 0.0)])
_SEGMENTS = np.array([(0.045, 0.032, 0.027), (0.042, 0.025, 0.020), (0.046, 0.028, 0.021),
                      (0.043, 0.027, 0.020), (0.034, 0.020, 0.018)])
#: Where the fingers' knuckles fan towards at zero spread (degrees, + to the thumb side).
_BASE_SPREAD = np.array([0.0, 4.0, 0.0, -4.0, -9.0])


def _rotate(v: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues: unit vectors v (..., 3) about unit axis (..., 3) by angle (...) radians."""
    c, s = np.cos(angle)[..., None], np.sin(angle)[..., None]
    return v * c + np.cross(axis, v) * s + axis * np.sum(axis * v, axis=-1, keepdims=True) * (1 - c)


def local_hand_joints(fingers: np.ndarray) -> np.ndarray:
    """Hand joint positions (..., 20, 3) in the hand's frame (x thumb side, y along the
    fingers, z out of the palm; metres from the wrist) for finger angles (..., 5, 4)."""
    f = np.radians(np.asarray(fingers, dtype=np.float64))
    lead = f.shape[:-2]
    out = np.zeros(lead + (20, 3))
    ex = np.broadcast_to(np.array([1.0, 0.0, 0.0]), lead + (3,))
    ey = np.broadcast_to(np.array([0.0, 1.0, 0.0]), lead + (3,))
    ez = np.broadcast_to(np.array([0.0, 0.0, 1.0]), lead + (3,))
    for d in range(5):
        a = f[..., d, :]
        root = np.broadcast_to(_ROOTS[d], lead + (3,))
        if d == 0:  # thumb: abduction in the palm plane from the index, opposition towards the palm
            base = _towards(ey, ex, a[..., 0])
            direction = _towards(base, ez, a[..., 1])
            bend = _unit(_reject(ez - 0.8 * ex, direction))  # curls over the palm, to the little finger
            flex = [None, a[..., 2], a[..., 3]]
        else:
            spread = np.radians(_BASE_SPREAD[d]) + a[..., 0] * (1.0 if d == 1 else (-1.0 if d >= 3 else 0.0))
            direction = _towards(_towards(ey, ex, spread), ez, a[..., 1])
            bend = _unit(_reject(ez, direction))
            flex = [None, a[..., 2], a[..., 3]]
        p = root
        out[..., 4 * d, :] = p
        for k in range(3):
            if k > 0:
                axis = _unit(np.cross(direction, bend))
                new = _rotate(direction, axis, flex[k])
                bend = _unit(_rotate(bend, axis, flex[k]))
                direction = new
            p = p + direction * _SEGMENTS[d, k]
            out[..., 4 * d + k + 1, :] = p
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _reject(v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """v without its component along unit ``axis``."""
    return v - np.sum(v * axis, axis=-1, keepdims=True) * axis


def _towards(v: np.ndarray, target: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Unit v turned by ``angle`` radians towards ``target`` (in their plane)."""
    perp = _unit(_reject(target, v))
    return _unit(v * np.cos(angle)[..., None] + perp * np.sin(angle)[..., None])


def hand_frames(forearm: np.ndarray, palm: np.ndarray, side: str, upper_arm: np.ndarray | None = None) -> np.ndarray:
    """Hand orientations (..., 3, 3), columns (thumb side, along the fingers, out of the palm),
    for forearm directions (elbow -> wrist, (..., 3)) and palm targets (..., 3).

    The hand turns about the forearm until its palm faces the target's part square to the
    forearm, then the wrist bends (at most :data:`MAX_WRIST_BEND`) towards the rest of it: a
    palm facing where the forearm points is a raised hand ("stop"), an extension.

    Where the target runs nearly along the forearm it says little about the roll, and the
    hand takes the forearm's neutral roll instead: with ``upper_arm`` (shoulder -> elbow
    directions) and a bent elbow, the palm facing across the bend (thumb up for a forearm
    held in front: no twist between elbow and wrist); else, or for a straight arm, "down",
    then "in"."""
    d = _unit(np.asarray(forearm, dtype=np.float64))
    n = _unit(np.asarray(palm, dtype=np.float64))
    # the target square to the forearm; near-parallel targets fall back to the neutral roll,
    # then "down", then "in", continuously, so the roll never flips within a frame's motion
    down = palm_direction("down", side) * np.ones_like(d)
    inward = palm_direction("in", side) * np.ones_like(d)
    fallbacks = [(down, 1.0), (inward, 1.0)]
    if upper_arm is not None:
        u = _unit(np.asarray(upper_arm, dtype=np.float64))
        neutral = np.cross(d, u) if side == "right" else np.cross(u, d)  # as long as the sine of the elbow's bend
        # trusted in full from a bend of 17 degrees, fading out as the arm straightens
        fallbacks.insert(0, (neutral, np.clip(np.linalg.norm(neutral, axis=-1, keepdims=True) / 0.3, 0.0, 1.0)))
    v = _reject(n, d)
    for fallback, weight in fallbacks:
        short = np.maximum(0.0, 0.25 - np.linalg.norm(v, axis=-1, keepdims=True))
        v = v + short * weight * _unit(_reject(fallback, d))
    p = _unit(v)
    # the wrist bends towards the target's part along the forearm
    along = np.clip(np.sum(n * d, axis=-1), -1.0, 1.0)
    bend = np.clip(np.arcsin(along), -math.radians(MAX_WRIST_BEND), math.radians(MAX_WRIST_BEND))
    # rotating (d, p) about their common normal: p turns towards d, the fingers away from the palm
    h = d * np.cos(bend)[..., None] - p * np.sin(bend)[..., None]
    p2 = p * np.cos(bend)[..., None] + d * np.sin(bend)[..., None]
    # the thumb side: right hand h x p, left hand p x h (mirror images)
    t = np.cross(h, p2) if side == "right" else np.cross(p2, h)
    return np.stack([t, h, p2], axis=-1)


#: The most a hand turns relative to its forearm in one frame to follow its palm target, about
#: the forearm (pronation, "roll") and across it (the wrist's bend), degrees (375 degrees/s
#: each at 15 fps): see :func:`steady_palms`.
MAX_ROLL_STEP = 25.0
MAX_BEND_STEP = 25.0


def steady_palms(positions: np.ndarray, track: HandTrack, max_roll: float = MAX_ROLL_STEP,
                 max_bend: float = MAX_BEND_STEP) -> HandTrack:
    """``track`` with palm targets that :func:`hand_frames` follows without a hand flipping or
    snapping.

    :func:`hand_frames` chooses each frame's hand on its own, and no rule that does so can be
    continuous everywhere: where the palm target runs nearly along the forearm (the end of a
    wave or a "stop", the arm swinging down past it) a slight move of the arm turns the hand
    round by up to 180 degrees in one frame, while the wrist sits at its bend limit on both
    sides; and a forearm swinging fast past a still target bends the wrist from one limit to
    the other in a frame or two. Here each hand's roll about the forearm (measured against the
    previous frame's, carried along as the forearm turns) changes by at most ``max_roll``
    degrees a frame, and its bend by at most ``max_bend``: where the hand :func:`hand_frames`
    would choose runs ahead, the hand turns towards it at that speed. On those frames the palm
    target becomes the direction the palm then faces, which :func:`hand_frames` reproduces
    exactly (a wrist bent at most :data:`MAX_WRIST_BEND` keeps more than the fallback's share
    of the target square to the forearm), so every reader of the track (renders, exports)
    draws the same hands; other frames keep their targets. ``positions`` (T, 10, 3): the
    body's joints on the track's frames."""
    x = np.asarray(positions, dtype=np.float64)
    palm = track.palm.astype(np.float64).copy()
    if len(x) < 2:
        return HandTrack(palm.astype(track.palm.dtype), track.fingers)
    roll_limit, bend_limit = math.radians(max_roll), math.radians(max_bend)
    for s, side in enumerate(SIDES):
        forearm = x[:, JOINT_INDEX[f"{side}_wrist"]] - x[:, JOINT_INDEX[f"{side}_elbow"]]
        upper = x[:, JOINT_INDEX[f"{side}_elbow"]] - x[:, JOINT_INDEX[f"{side}_shoulder"]]
        d = _unit(forearm)
        normal = hand_frames(forearm, palm[:, s], side, upper)[..., 2]
        bend = np.arcsin(np.clip(np.sum(normal * d, axis=-1), -1.0, 1.0))
        roll = _unit(_reject(normal, d))  # the roll's direction: the palm square to the forearm
        # each frame's roll change, the previous roll carried onto this frame's forearm
        carried = _carry(roll[:-1], d[:-1], d[1:])
        step = np.arctan2(np.sum(np.cross(carried, roll[1:]) * d[1:], axis=-1), np.sum(carried * roll[1:], axis=-1))
        if np.abs(step).max() <= roll_limit + 1e-9 and np.abs(np.diff(bend)).max() <= bend_limit + 1e-9:
            continue
        wanted = np.concatenate([[0.0], np.cumsum(step)])
        got_roll, got_bend = _follow(wanted, roll_limit), _follow(bend, bend_limit)
        late = (np.abs(got_roll - wanted) > 1e-9) | (np.abs(got_bend - bend) > 1e-9)
        turned = _rotate(roll[late], d[late], (got_roll - wanted)[late])
        b = got_bend[late][:, None]
        palm[late, s] = turned * np.cos(b) + d[late] * np.sin(b)
    return HandTrack(palm.astype(track.palm.dtype), track.fingers)


def _follow(wanted: np.ndarray, limit: float) -> np.ndarray:
    """``wanted`` (T,) followed from its first value, moving at most ``limit`` a step."""
    got = wanted.copy()
    for t in range(1, len(got)):  # a scalar recursion: microseconds a frame
        got[t] = got[t - 1] + min(limit, max(-limit, wanted[t] - got[t - 1]))
    return got


def _carry(v: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Vectors ``v`` (n, 3) turned by the least rotation that takes unit ``a`` to unit ``b``."""
    axis = np.cross(a, b)
    sin = np.linalg.norm(axis, axis=-1)
    cos = np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)
    angle = np.arctan2(sin, cos)
    safe = sin > 1e-9
    unit_axis = np.where(safe[:, None], axis / np.maximum(sin, 1e-12)[:, None], 0.0)
    return np.where(safe[:, None], _rotate(v, unit_axis, angle), v)


def hand_positions(positions: np.ndarray, track: HandTrack) -> np.ndarray:
    """World positions of the hand joints (T, 2, 20, 3) (side order :data:`SIDES`) from the
    body's joint positions (T, 10, 3) and a hand track."""
    x = np.asarray(positions, dtype=np.float64)
    out = np.zeros((x.shape[0], 2, 20, 3))
    local = local_hand_joints(track.fingers)  # (T, 2, 20, 3)
    for s, side in enumerate(SIDES):
        wrist = x[:, JOINT_INDEX[f"{side}_wrist"]]
        forearm = wrist - x[:, JOINT_INDEX[f"{side}_elbow"]]
        upper = x[:, JOINT_INDEX[f"{side}_elbow"]] - x[:, JOINT_INDEX[f"{side}_shoulder"]]
        frames = hand_frames(forearm, track.palm[:, s], side, upper)  # (T, 3, 3)
        out[:, s] = wrist[:, None, :] + np.einsum("tij,tkj->tki", frames, local[:, s])
    return out

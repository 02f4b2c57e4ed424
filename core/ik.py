"""Posing the skeleton by hand: inverse kinematics at the skeleton's fixed bone lengths (numpy only).

Every function takes a pose (27 numbers: the unit bone directions of :mod:`core.skeleton`) and
returns a new pose (float64, shape (27,)); none changes its input. Bone lengths never change:
a pose holds directions only, and the joints are where :func:`core.skeleton.positions_from_pose`
puts them (the root, ``spine``, at :data:`core.skeleton.ROOT_POSITION`).

- :func:`solve_arm`: put a wrist at a point. An exact two-bone solve: the shoulder stays, the
  wrist goes to the target, and the elbow to the point of the circle of elbows that reach it
  chosen by the **swivel** (:func:`swivel`: the elbow's turn about the shoulder-wrist line), by a
  ``pole`` (the elbow goes as near it as it can: the elbow's own handle), or, with neither, as
  near as it can to where it was. A target out of reach (farther than the straight arm, or
  nearer than the elbow bends, :data:`ELBOW_FLEXION`) is moved to the nearest point in reach:
  along the line from the shoulder.
- :func:`set_head`: the head (the ``nose`` and ``head_top`` bones, turned together) at a yaw,
  pitch and roll (:func:`head_angles`), within :data:`HEAD_LIMITS`.
- :func:`set_torso`: the torso (the ``neck`` bone) leaning towards a direction, at most
  :data:`TORSO_LEAN` from upright; :func:`set_shoulder`: a shoulder raised or pushed forward
  (the ``*_shoulder`` bone), within :data:`SHOULDER_ELEVATION` and :data:`SHOULDER_PROTRACTION`.
  Only that bone turns: the bones below keep their directions, as a gesture spec has them (a
  lean names the neck alone, and the arms hang as they did).
- :func:`twist_palm`: the forearm's twist. The skeleton has no twist of its own; the hand turns
  about the forearm to face its palm target (:func:`core.hands.hand_frames`), and specs name
  palms (:data:`core.hands.PALMS`), so a twist is the named palm nearest the current one turned
  about the forearm by that angle.

``viewer/src/ik.js`` is the same code for ``sgt view``'s page; tests/test_pose_ik.py checks that
the two agree within 1e-6.
"""

from __future__ import annotations

import math

import numpy as np

from core.hands import PALMS, nearest_palm, palm_direction
from core.skeleton import BONE_INDEX, BONE_LENGTHS, JOINT_INDEX, POSE_DIM, REST_DIRECTIONS, positions_from_pose

SIDES = ("left", "right")
#: The elbow's flexion, degrees: 0 is a straight arm. The library's gestures bend it up to 152.
ELBOW_FLEXION = (0.0, 155.0)
#: The head's turn from its rest, degrees: yaw (+ towards the character's left), pitch (+ the face
#: down, a nod), roll (+ the head tilted towards the character's right shoulder).
HEAD_LIMITS = {"yaw": (-80.0, 80.0), "pitch": (-50.0, 60.0), "roll": (-40.0, 40.0)}
#: The torso's lean from upright, degrees at most (the library's bow leans 24).
TORSO_LEAN = 45.0
#: A shoulder bone's elevation (+ up, the shrug turns it 32) and protraction (+ forward), degrees.
SHOULDER_ELEVATION = (-20.0, 40.0)
SHOULDER_PROTRACTION = (-30.0, 30.0)
#: Swivel 0: the elbow towards this direction from the shoulder-wrist line (down and back: an arm
#: held forward has its elbow below it, a hanging arm behind it).
SWIVEL_REFERENCE = np.array([0.0, -1.0, -1.0]) / math.sqrt(2.0)
_UP = np.array([0.0, 1.0, 0.0])


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 0 else v


def _reject(v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """``v`` without its part along the unit ``axis``."""
    return v - float(v @ axis) * axis


def _pose(pose) -> np.ndarray:
    p = np.array(pose, dtype=np.float64).reshape(-1)
    if p.shape != (POSE_DIM,) or not np.all(np.isfinite(p)):
        raise ValueError(f"a pose is {POSE_DIM} finite numbers, got shape {np.shape(pose)}")
    return p


def _set(p: np.ndarray, bone: str, direction: np.ndarray) -> None:
    i = 3 * BONE_INDEX[bone]
    p[i : i + 3] = _unit(direction)


def _get(p: np.ndarray, bone: str) -> np.ndarray:
    i = 3 * BONE_INDEX[bone]
    return p[i : i + 3].copy()


def _side(side: str) -> str:
    if side not in SIDES:
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    return side


# -- arms ------------------------------------------------------------------------------------


def reach(side: str = "right") -> tuple[float, float]:
    """The nearest and farthest a wrist gets from its shoulder (metres), at the elbow's limits."""
    a, b = BONE_LENGTHS[f"{_side(side)}_elbow"], BONE_LENGTHS[f"{side}_wrist"]
    lo, hi = (math.radians(x) for x in ELBOW_FLEXION)
    # flexion f: the angle between the bones' directions; the shoulder-wrist distance shrinks with it
    return (math.sqrt(a * a + b * b + 2 * a * b * math.cos(hi)), math.sqrt(a * a + b * b + 2 * a * b * math.cos(lo)))


def elbow_flexion(pose, side: str) -> float:
    """The elbow's flexion in degrees (0: a straight arm)."""
    p = _pose(pose)
    u, f = _unit(_get(p, f"{_side(side)}_elbow")), _unit(_get(p, f"{side}_wrist"))
    return math.degrees(math.acos(max(-1.0, min(1.0, float(u @ f)))))


def _swivel_frame(axis: np.ndarray, side: str) -> tuple[np.ndarray, np.ndarray]:
    """(swivel 0, swivel +90) directions square to the unit shoulder-wrist ``axis``: + turns the
    elbow out, away from the body (mirror images for the two arms)."""
    zero = _reject(SWIVEL_REFERENCE, axis)
    if np.linalg.norm(zero) < 1e-6:  # the arm along the reference: the elbow out instead
        zero = _reject(np.array([-1.0 if side == "right" else 1.0, 0.0, 0.0]), axis)
    zero = _unit(zero)
    out = np.cross(axis, zero) * (-1.0 if side == "right" else 1.0)
    return zero, out


def swivel(pose, side: str) -> float:
    """The elbow's swivel in degrees: its turn about the shoulder-wrist line from
    :data:`SWIVEL_REFERENCE`, + out, away from the body (0 for a straight arm)."""
    p = _pose(pose)
    x = positions_from_pose(p)
    s, e, w = (x[JOINT_INDEX[f"{_side(side)}_{j}"]] for j in ("shoulder", "elbow", "wrist"))
    axis = _unit(w - s)
    off = _reject(e - s, axis)
    if np.linalg.norm(off) < 1e-9:
        return 0.0
    zero, out = _swivel_frame(axis, side)
    return math.degrees(math.atan2(float(off @ out), float(off @ zero)))


def solve_arm(pose, side: str, target, *, swivel: float | None = None, pole=None) -> np.ndarray:
    """``pose`` with the ``side`` wrist at ``target`` (metres, the skeleton's coordinates), or at
    the nearest point in reach; the shoulder stays. The elbow: at ``swivel`` degrees
    (:func:`swivel`), else as near ``pole`` (a point) as it can, else as near as it can to where
    it was."""
    p = _pose(pose)
    side = _side(side)
    a, b = BONE_LENGTHS[f"{side}_elbow"], BONE_LENGTHS[f"{side}_wrist"]
    x = positions_from_pose(p)
    s, e, w = (x[JOINT_INDEX[f"{side}_{j}"]] for j in ("shoulder", "elbow", "wrist"))
    t = np.asarray(target, dtype=np.float64).reshape(3)
    if not np.all(np.isfinite(t)):
        raise ValueError("the target must be 3 finite numbers")
    lo, hi = reach(side)
    v = t - s
    d = float(np.linalg.norm(v))
    axis = _unit(v) if d > 1e-9 else _unit(w - s)
    d = min(max(d, lo), hi)
    # the circle of elbows: centre at `along` from the shoulder on the axis, radius `radius`
    along = (a * a - b * b + d * d) / (2 * d)
    radius = math.sqrt(max(a * a - along * along, 0.0))
    zero, out = _swivel_frame(axis, side)
    if swivel is not None:
        angle = math.radians(float(swivel))
        toward = math.cos(angle) * zero + math.sin(angle) * out
    else:
        toward = _reject((e if pole is None else np.asarray(pole, dtype=np.float64).reshape(3)) - s, axis)
        toward = _unit(toward) if np.linalg.norm(toward) > 1e-9 else zero
    elbow = s + along * axis + radius * toward
    wrist = s + d * axis
    _set(p, f"{side}_elbow", elbow - s)
    _set(p, f"{side}_wrist", wrist - elbow)
    return p


# -- the head --------------------------------------------------------------------------------

def _head_frame(nose: np.ndarray, top: np.ndarray) -> np.ndarray:
    """An orthonormal frame (columns) of the head from its two bones: the nose, then the head top
    square to it, then their cross product."""
    f = _unit(nose)
    u = _unit(_reject(top, f))
    return np.stack([f, u, np.cross(f, u)], axis=1)


_REST_HEAD = _head_frame(np.asarray(REST_DIRECTIONS["nose"]), np.asarray(REST_DIRECTIONS["head_top"]))


def _rotation(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """Ry(yaw) Rx(pitch) Rz(roll), degrees."""
    y, x, z = (math.radians(v) for v in (yaw, pitch, roll))
    ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    rx = np.array([[1, 0, 0], [0, math.cos(x), -math.sin(x)], [0, math.sin(x), math.cos(x)]])
    rz = np.array([[math.cos(z), -math.sin(z), 0], [math.sin(z), math.cos(z), 0], [0, 0, 1]])
    return ry @ rx @ rz


def _angles(r: np.ndarray) -> tuple[float, float, float]:
    pitch = math.asin(max(-1.0, min(1.0, -float(r[1, 2]))))
    yaw = math.atan2(float(r[0, 2]), float(r[2, 2]))
    roll = math.atan2(float(r[1, 0]), float(r[1, 1]))
    return math.degrees(yaw), math.degrees(pitch), math.degrees(roll)


def head_rotation(pose) -> np.ndarray:
    """The rotation (3, 3) that turns the rest head into the pose's head."""
    p = _pose(pose)
    return _head_frame(_get(p, "nose"), _get(p, "head_top")) @ _REST_HEAD.T


def head_angles(pose) -> tuple[float, float, float]:
    """The head's (yaw, pitch, roll) from its rest, degrees (:data:`HEAD_LIMITS` says which way)."""
    return _angles(head_rotation(pose))


def set_head(pose, yaw: float, pitch: float, roll: float) -> np.ndarray:
    """``pose`` with the head turned to (yaw, pitch, roll) degrees from its rest, each clamped to
    :data:`HEAD_LIMITS`; the head's two bones turn together (their angle is kept)."""
    p = _pose(pose)
    angles = [min(max(float(v), lo), hi) for v, (lo, hi) in zip((yaw, pitch, roll), HEAD_LIMITS.values())]
    turn = _rotation(*angles) @ head_rotation(p).T
    for bone in ("nose", "head_top"):
        _set(p, bone, turn @ _get(p, bone))
    return p


# -- torso and shoulders ---------------------------------------------------------------------


def _clamp_cone(direction: np.ndarray, axis: np.ndarray, degrees: float) -> np.ndarray:
    """The unit ``direction`` turned towards the unit ``axis`` until it is at most ``degrees`` from it."""
    d = _unit(direction)
    angle = math.acos(max(-1.0, min(1.0, float(d @ axis))))
    limit = math.radians(degrees)
    if angle <= limit:
        return d
    side = _reject(d, axis)
    side = _unit(side) if np.linalg.norm(side) > 1e-9 else _unit(_reject(np.array([0.0, 0.0, 1.0]), axis))
    return math.cos(limit) * axis + math.sin(limit) * side


def set_torso(pose, direction) -> np.ndarray:
    """``pose`` with the torso (spine -> neck) along ``direction``, at most :data:`TORSO_LEAN`
    degrees from upright."""
    p = _pose(pose)
    d = np.asarray(direction, dtype=np.float64).reshape(3)
    if not np.all(np.isfinite(d)) or np.linalg.norm(d) < 1e-9:
        raise ValueError("the direction must be 3 finite numbers, not all 0")
    _set(p, "neck", _clamp_cone(d, _UP, TORSO_LEAN))
    return p


def shoulder_angles(pose, side: str) -> tuple[float, float]:
    """A shoulder bone's (elevation, protraction) in degrees: + up; + forward, from straight out
    to the side."""
    v = _unit(_get(_pose(pose), f"{_side(side)}_shoulder"))
    out = -1.0 if side == "right" else 1.0  # the shoulder's side of the body, on x
    return (math.degrees(math.asin(max(-1.0, min(1.0, float(v[1]))))),
            math.degrees(math.atan2(float(v[2]), float(v[0]) * out)))


def set_shoulder(pose, side: str, direction) -> np.ndarray:
    """``pose`` with the ``side`` shoulder bone (neck -> shoulder) towards ``direction``, its
    elevation and protraction clamped to their limits; the arm keeps its directions."""
    p = _pose(pose)
    side = _side(side)
    d = _unit(np.asarray(direction, dtype=np.float64).reshape(3))
    if not np.all(np.isfinite(d)) or np.linalg.norm(d) < 0.5:
        raise ValueError("the direction must be 3 finite numbers, not all 0")
    out = -1.0 if side == "right" else 1.0  # the shoulder's side of the body, on x
    lo_e, hi_e = (math.radians(v) for v in SHOULDER_ELEVATION)
    lo_p, hi_p = (math.radians(v) for v in SHOULDER_PROTRACTION)
    elevation = min(max(math.asin(max(-1.0, min(1.0, float(d[1])))), lo_e), hi_e)
    protraction = min(max(math.atan2(float(d[2]), float(d[0]) * out), lo_p), hi_p)
    flat = math.cos(elevation)
    _set(p, f"{side}_shoulder", np.array([out * flat * math.cos(protraction), math.sin(elevation), flat * math.sin(protraction)]))
    return p


# -- the forearm's twist ---------------------------------------------------------------------


def twist_palm(pose, side: str, palm: str, degrees: float) -> str:
    """The named palm (:data:`core.hands.PALMS`) nearest to palm ``palm`` turned about the
    ``side`` forearm by ``degrees`` (+ turns the palm up for a forearm held forward with the palm
    in: supination, on both arms)."""
    if palm not in PALMS:
        raise ValueError(f"unknown palm {palm!r} (one of {', '.join(PALMS)})")
    p = _pose(pose)
    side = _side(side)
    axis = _unit(_get(p, f"{side}_wrist"))
    n = palm_direction(palm, side)
    angle = math.radians(float(degrees)) * (1.0 if side == "right" else -1.0)
    c, s = math.cos(angle), math.sin(angle)
    turned = n * c + np.cross(axis, n) * s + axis * float(axis @ n) * (1 - c)
    return nearest_palm(turned, side)

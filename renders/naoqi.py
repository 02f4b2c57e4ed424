"""Humanoid robots: NAO (v6) and Pepper joint angles solved from sgt's skeleton, for NAOqi.

Inverse kinematics is analytic per chain (no iteration):

- The torso frame follows sgt's torso: y from spine to neck, x along the shoulder line (right
  to left shoulder), its rotation from sgt's rest is taken out, so the robot's arms and head
  move relative to its own torso. Axes: NAOqi's (x forward, y left, z up) = sgt's (z, x, y).
- HipPitch (Pepper only) keeps the torso's lean, forward or back (a bow, ``lean_forward``,
  ``lean_back``): the angle of sgt's spine -> neck from the vertical in the plane of the
  torso's heading. NAOqi's sign: the torso is the URDF's root and the legs hang from the hip,
  so a positive HipPitch turns the legs (about +y: their -z towards -x) back under the torso,
  which leans the upper body back over the wheels; a bow is negative.
  Pepper's HipRoll and KneePitch and the torso's sideways lean and twist are not driven. NAO
  leans only through its leg joints (whole-body balance), so its torso stays upright and its
  arms and head keep sgt's, relative to the torso.
- Shoulder: the upper arm (shoulder -> elbow) gives ShoulderPitch (about y) and ShoulderRoll
  (about z), correcting for the elbow's sideways offset (ElbowOffsetY). Elbow: the forearm in the
  shoulder frame gives ElbowRoll (its bend, the sign the robot's limits allow) and ElbowYaw (the
  upper arm's twist). A (nearly: bend under 2 degrees) straight arm leaves ElbowYaw undefined: it keeps the previous frame's.
- Head: the head's turn relative to the torso (sgt's neck->head_top and neck->nose frame) moves
  the face's forward axis; its yaw and pitch are HeadYaw and HeadPitch (head roll is lost: the
  robots have no roll joint).
- Hand (0 closed .. 1 open, Pepper 0.02 .. 0.98) is how open sgt's hand is
  (:func:`core.hands.openness`: the four fingers' mean flexion against a fist's) scaled to the
  robot's range, so a fist, a point or a thumbs up close the robot's hand and an open palm
  opens it.
- WristYaw turns the hand about the forearm so that its palm faces the way sgt's palm faces,
  square to the forearm (:func:`core.hands.hand_frames`: the palm after its turn, without the
  wrist's bend, which the robots lack). At WristYaw 0 the robots' palms face their forearm
  frame's -z (NAO's HandOffsetZ puts the hand 12.31 mm below the wrist axis and its
  back-of-hand touch sensor at +z; Pepper's thumb sits at -z on the midline side), and a
  positive WristYaw turns the palm towards the forearm frame's +y (about the URDF's x axis): a
  right palm turning from down to up goes positive, a left one negative. The forearm frame is
  the solved (unclamped) arm's; a palm beyond the joint's 104.5 degrees is clamped at the limit.

Then every angle is clamped to the joint's range, and frame-to-frame changes to the joint's
maximum speed (a forward pass: each frame moves at most ``velocity / 15`` radians from the
previous output frame).

Robot data, with sources (radians, rad/s, metres):

- NAO v6 ranges: Aldebaran's NAO joints pages (doc.aldebaran.com, "NAO - Joints", the V4.0+
  table, unchanged in v5 and v6: https://www.cs.cmu.edu/~cga/nao/doc/reference-documentation/
  nao/hardware/kinematics/nao-joints-40.html, mirror of doc.aldebaran.com/2-8/family/
  nao_technical/joints_naov6.html). Speeds: the ``velocity`` of each joint's ``<limit>`` in
  Aldebaran's generated URDF (ros-naoqi/nao_robot, nao_description/urdf/naoV50_generated_urdf/
  nao.urdf): 8.26797 for HeadYaw, ShoulderPitch and ElbowYaw (reduction 150.27), 7.19407 for
  HeadPitch, ShoulderRoll and ElbowRoll (173.22), 24.6229 for WristYaw, 8.33 for Hand. Links:
  "NAO - Links" (V3.3 and later): UpperArmLength 0.105, ElbowOffsetY 0.015, LowerArmLength
  0.05595.
- Pepper (1.8): ranges, speeds and links from Aldebaran's generated URDF
  (ros-naoqi/pepper_robot, pepper_description/urdf/pepper1.0_generated_urdf/pepper.urdf, the
  values of doc.aldebaran.com/2-5/family/pepper_technical/joints_pep.html): upper arm
  (0.1812, 0.015, 0.00013), ElbowYaw frame pitched by -0.157079 rad, forearm 0.15; HipPitch
  -1.03847 .. 1.03847 at 2.93276 rad/s.
"""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass

import numpy as np

from core.fileio import atomic_write
from core.hands import SIDES, hand_frames, openness
from core.motion import MotionClip
from core.skeleton import FPS
from renders.rigs.retarget import source_positions, source_rest
from renders.rotations import triads

ARM = ("ShoulderPitch", "ShoulderRoll", "ElbowYaw", "ElbowRoll", "WristYaw", "Hand")
#: The head and arm joints both robots take (all of NAO's file); Pepper's adds :data:`PEPPER_EXTRA`.
NAMES = ("HeadYaw", "HeadPitch") + tuple("L" + j for j in ARM) + tuple("R" + j for j in ARM)
PEPPER_EXTRA = ("HipPitch",)


@dataclass(frozen=True)
class Robot:
    name: str
    title: str
    limits: dict[str, tuple[float, float]]
    velocity: dict[str, float]  # rad/s
    upper_arm: tuple[float, float, float]  # shoulder -> elbow in the ShoulderRoll frame, left arm
    elbow_pitch: float  # fixed pitch of the ElbowYaw frame relative to the ShoulderRoll frame
    names: tuple[str, ...] = NAMES  # the joints written, in file order


def _mirror(left: dict[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    out = dict(left)
    for j in ARM:
        lo, hi = left["L" + j]
        out["R" + j] = (-hi, -lo) if j in ("ShoulderRoll", "ElbowRoll", "ElbowYaw", "WristYaw") else (lo, hi)
    return out


def _sym(left: dict[str, float]) -> dict[str, float]:
    return {**left, **{"R" + k[1:]: v for k, v in left.items() if k.startswith("L")}}


NAO = Robot(
    name="nao", title="NAO v6",
    limits=_mirror({
        "HeadYaw": (-2.0857, 2.0857), "HeadPitch": (-0.6720, 0.5149),
        "LShoulderPitch": (-2.0857, 2.0857), "LShoulderRoll": (-0.3142, 1.3265),
        "LElbowYaw": (-2.0857, 2.0857), "LElbowRoll": (-1.5446, -0.0349),
        "LWristYaw": (-1.8238, 1.8238), "LHand": (0.0, 1.0),
    }),
    # rad/s: each joint's <limit velocity> in Aldebaran's generated URDF for NAO (ros-naoqi/nao_robot,
    # nao_description/urdf/naoV50_generated_urdf/nao.urdf), the same for both arms
    velocity=_sym({
        "HeadYaw": 8.26797, "HeadPitch": 7.19407,
        "LShoulderPitch": 8.26797, "LShoulderRoll": 7.19407,
        "LElbowYaw": 8.26797, "LElbowRoll": 7.19407,
        "LWristYaw": 24.6229, "LHand": 8.33,
    }),
    upper_arm=(0.105, 0.015, 0.0), elbow_pitch=0.0,
)

PEPPER = Robot(
    name="pepper", title="Pepper 1.8",
    limits=_mirror({
        "HeadYaw": (-2.08567, 2.08567), "HeadPitch": (-0.706858, 0.637045),
        "LShoulderPitch": (-2.08567, 2.08567), "LShoulderRoll": (0.00872665, 1.56207),
        "LElbowYaw": (-2.08567, 2.08567), "LElbowRoll": (-1.56207, -0.00872665),
        "LWristYaw": (-1.82387, 1.82387), "LHand": (0.02, 0.98), "HipPitch": (-1.03847, 1.03847),
    }),
    velocity=_sym({
        "HeadYaw": 7.33998, "HeadPitch": 9.22756, "LShoulderPitch": 7.33998, "LShoulderRoll": 9.22756,
        "LElbowYaw": 7.33998, "LElbowRoll": 9.22756, "LWristYaw": 17.3835, "LHand": 12.56, "HipPitch": 2.93276,
    }),
    upper_arm=(0.1812, 0.015, 0.00013), elbow_pitch=-0.157079, names=NAMES + PEPPER_EXTRA,
)

ROBOTS = {"nao": NAO, "pepper": PEPPER}

# sgt (x left, y up, z forward) -> NAOqi (x forward, y left, z up)
_TO_NAO = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def _frame(j: dict, primary: tuple[str, str], secondary: tuple[str, str]) -> np.ndarray:
    return triads(j[primary[1]] - j[primary[0]], j[secondary[1]] - j[secondary[0]])


def _unit(v):
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def torso_directions(clip: MotionClip) -> dict[str, np.ndarray]:
    """sgt's arm bone directions, head forward axis and palms (the palm's direction square to
    the forearm) in the robot torso frame (NAOqi axes), (T, 3); and ``lean`` (T,), the torso's
    lean in radians, forward positive (spine -> neck from the vertical, in the plane of the
    torso's heading)."""
    j, rest = source_positions(clip), source_rest()
    torso = ("spine", "neck"), ("right_shoulder", "left_shoulder")
    head = ("neck", "head_top"), ("neck", "nose")
    d_torso = _frame(j, *torso) @ _frame(rest, *torso).T  # torso's turn from its rest, world
    d_head = _frame(j, *head) @ _frame(rest, *head).T
    to_torso = _TO_NAO @ np.swapaxes(d_torso, -1, -2)  # world -> torso frame -> NAOqi axes

    out = {"head": to_torso @ d_head @ np.array([0.0, 0.0, 1.0])}
    up = d_torso @ np.array([0.0, 1.0, 0.0])  # spine -> neck (the rest torso is upright)
    heading = (d_torso @ np.array([0.0, 0.0, 1.0])) * np.array([1.0, 0.0, 1.0])  # its front, level
    out["lean"] = np.arctan2(np.sum(up * _unit(heading), axis=-1), up[:, 1])
    for s_index, side in enumerate(SIDES):
        s, e, w = (j[f"{side}_{n}"] for n in ("shoulder", "elbow", "wrist"))
        out[f"{side}_upper"] = _unit(np.einsum("tij,tj->ti", to_torso, e - s))
        out[f"{side}_fore"] = _unit(np.einsum("tij,tj->ti", to_torso, w - e))
        # the palm as sgt draws it (core.hands.hand_frames), less the wrist's bend: square to the forearm
        fore = _unit(w - e)
        palm = hand_frames(fore, clip.hands.palm[:, s_index].astype(np.float64), side)[..., 2]
        palm = _unit(palm - np.sum(palm * fore, axis=-1, keepdims=True) * fore)
        out[f"{side}_palm"] = np.einsum("tij,tj->ti", to_torso, palm)
    return out


def _wrist_yaw(forearm_frame: np.ndarray, palm: np.ndarray) -> np.ndarray:
    """WristYaw (T,) in (-pi, pi] that turns the palm (the forearm frame's -z at 0) towards
    ``palm`` (T, 3, torso frame) about the forearm frame's x. Not unwrapped: the joint turns
    104.5 degrees either way, so a palm that needs more than that is clamped at the limit, and
    the ElbowYaw branch flips of a nearly straight arm must not wind it round and round."""
    v = np.einsum("tji,tj->ti", forearm_frame, palm)  # the palm in the forearm frame
    return np.arctan2(v[:, 1], -v[:, 2])  # Rx(yaw) (0, 0, -1) = (0, sin yaw, -cos yaw)


def _hold_undefined(values: np.ndarray, defined: np.ndarray) -> np.ndarray:
    """Where ``defined`` is False, repeat the last defined value (the first defined one before it)."""
    if not defined.any():
        return np.zeros_like(values)
    idx = np.where(defined, np.arange(len(values)), -1)
    idx = np.maximum.accumulate(idx)
    idx[idx < 0] = int(np.argmax(defined))
    return values[idx]


def solve_raw(clip: MotionClip, robot: Robot) -> dict[str, np.ndarray]:
    """Unclamped joint angles (radians, (T,) each) that reproduce sgt's directions."""
    d = torso_directions(clip)
    out: dict[str, np.ndarray] = {}
    f = d["head"]
    out["HeadYaw"] = np.arctan2(f[:, 1], f[:, 0])
    out["HeadPitch"] = np.arctan2(-f[:, 2], np.hypot(f[:, 0], f[:, 1]))
    for side, p, sign in (("left", "L", 1.0), ("right", "R", -1.0)):
        ux, uy, _ = robot.upper_arm
        delta = sign * math.atan2(uy, ux)  # the elbow sits off the shoulder's x axis
        u = d[f"{side}_upper"]
        pitch = np.arctan2(-u[:, 2], u[:, 0])
        roll = np.arcsin(np.clip(u[:, 1], -1.0, 1.0)) - delta
        frame = _ry(pitch) @ _rz(roll) @ _ry(np.full_like(pitch, robot.elbow_pitch))
        fl = np.einsum("tji,tj->ti", frame, d[f"{side}_fore"])  # forearm in the ElbowYaw frame
        bend = np.arccos(np.clip(fl[:, 0], -1.0, 1.0))
        # fl = (cos er, sin er cos ey, sin er sin ey); left elbows bend with er < 0, right with er > 0
        elbow_roll = -sign * bend
        s = np.sin(elbow_roll)
        yaw = np.arctan2(fl[:, 2] / np.where(np.abs(s) > 1e-9, s, 1.0), fl[:, 1] / np.where(np.abs(s) > 1e-9, s, 1.0))
        yaw = _hold_undefined(yaw, bend > math.radians(2.0))
        out[p + "ShoulderPitch"], out[p + "ShoulderRoll"] = pitch, roll
        out[p + "ElbowYaw"], out[p + "ElbowRoll"] = yaw, elbow_roll
        out[p + "WristYaw"] = _wrist_yaw(frame @ _rx(yaw) @ _rz(elbow_roll), d[f"{side}_palm"])
        lo, hi = robot.limits[p + "Hand"]  # Pepper's hands open 0.02 .. 0.98: fist and flat hand map to its ends
        out[p + "Hand"] = lo + (hi - lo) * openness(clip.hands.fingers[:, SIDES.index(side)])
    out["HipPitch"] = -d["lean"]  # NAOqi: positive HipPitch leans the upper body back
    return {n: out[n] for n in robot.names}


@dataclass
class Solution:
    robot: Robot
    angles: dict[str, np.ndarray]  # name -> (T,) radians, clamped
    raw: dict[str, np.ndarray]
    position_clamped: dict[str, np.ndarray]  # name -> (T,) bool
    velocity_clamped: dict[str, np.ndarray]

    @property
    def names(self) -> tuple[str, ...]:
        return self.robot.names

    @property
    def n_frames(self) -> int:
        return len(self.angles[NAMES[0]])

    def times(self) -> np.ndarray:
        """Key times for angleInterpolation: frame i is reached at (i + 1) / 15 s."""
        return (np.arange(self.n_frames) + 1) / FPS


def solve(clip: MotionClip, robot: Robot) -> Solution:
    raw = solve_raw(clip, robot)
    angles, pos_c, vel_c = {}, {}, {}
    step_dt = 1.0 / FPS
    for n in robot.names:
        lo, hi = robot.limits[n]
        a = np.clip(raw[n], lo, hi)
        pos_c[n] = (raw[n] < lo - 1e-12) | (raw[n] > hi + 1e-12)
        step = robot.velocity[n] * step_dt
        out = a.copy()
        vc = np.zeros(len(a), dtype=bool)
        for t in range(1, len(a)):
            d = a[t] - out[t - 1]
            if abs(d) > step:
                out[t] = out[t - 1] + math.copysign(step, d)
                vc[t] = True
        angles[n], vel_c[n] = out, vc
    return Solution(robot=robot, angles=angles, raw=raw, position_clamped=pos_c, velocity_clamped=vel_c)


def angle_interpolation(solution: Solution) -> dict:
    """The arguments of ALMotion.angleInterpolation(names, angleLists, timeLists, isAbsolute=True)."""
    times = [round(float(t), 6) for t in solution.times()]
    names = solution.names
    return {
        "names": list(names),
        "angleLists": [[round(float(a), 5) for a in solution.angles[n]] for n in names],
        "timeLists": [times for _ in names],
    }


def csv_text(solution: Solution) -> str:
    buf = io.StringIO()
    buf.write("time," + ",".join(solution.names) + "\n")
    for i, t in enumerate(solution.times()):
        buf.write(f"{t:.6f}," + ",".join(f"{solution.angles[n][i]:.5f}" for n in solution.names) + "\n")
    return buf.getvalue()


def write_angles(path, clip: MotionClip, robot: Robot, kind: str) -> Solution:
    """Write ``kind`` "json" (angleInterpolation arguments) or "csv"; returns the solution."""
    sol = solve(clip, robot)
    text = json.dumps(angle_interpolation(sol)) if kind == "json" else csv_text(sol)
    atomic_write(path, text.encode("utf-8"))
    return sol

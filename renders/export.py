"""Exports of motion clips: BVH (joint rotations) and CSV (joint positions).

BVH hierarchy (all names are skeleton joint names except the two zero-length collars)::

    ROOT spine            6 channels: Xposition Yposition Zposition Zrotation Xrotation Yrotation
      neck                3 channels: Zrotation Xrotation Yrotation (every JOINT below too)
        nose
          head_top        End Site 0.05 m on along the head
        left_collar       OFFSET 0 0 0
          left_shoulder
            left_elbow
              left_wrist  End Site 0.08 m on along the forearm
        right_collar      OFFSET 0 0 0
          right_shoulder ...

A joint's rotation turns the bone from it to its child: spine -> neck, neck -> nose,
nose -> head_top, left_collar -> left_shoulder, left_shoulder -> left_elbow,
left_elbow -> left_wrist. The collars exist because one BVH rotation can orient only one
bone, and the neck starts three. OFFSETs are the rest-pose bone vectors
(:data:`core.skeleton.REST_DIRECTIONS` times the bone lengths) in metres, so all-zero
rotations give the rest pose. head_top and the wrists carry zero rotations.

Roll: the skeleton stores bone directions only, so twist about a bone is undefined. The
convention is: the world rotation of every bone is the shortest-arc rotation from its
rest direction to its direction in the frame (no twist relative to the rest pose); local
rotations are parent^-1 * child. Euler angles are intrinsic Z, X, Y in degrees
(R = Rz Rx Ry, the order of the channels).
"""

from __future__ import annotations

import io
import warnings

import numpy as np

from core.fileio import atomic_write
from core.motion import MotionClip
from core.skeleton import BONE_LENGTHS, BONES, FPS, JOINT_INDEX, JOINTS, REST_DIRECTIONS
from renders.rotations import shortest_arc

ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
EULER_ORDER = "ZXY"  # intrinsic: R = Rz @ Rx @ Ry
END_SITES = {"head_top": 0.05, "left_wrist": 0.08, "right_wrist": 0.08}


def _rest_vector(bone: str) -> np.ndarray:
    return np.asarray(REST_DIRECTIONS[bone], dtype=np.float64) * BONE_LENGTHS[bone]


# (joint, parent, offset, bone it drives or None)
def _hierarchy() -> list[tuple[str, str | None, np.ndarray, str | None]]:
    z = np.zeros(3)
    h = [
        ("spine", None, z, "neck"),
        ("neck", "spine", _rest_vector("neck"), "nose"),
        ("nose", "neck", _rest_vector("nose"), "head_top"),
        ("head_top", "nose", _rest_vector("head_top"), None),
    ]
    for side in ("left", "right"):
        h += [
            (f"{side}_collar", "neck", z, f"{side}_shoulder"),
            (f"{side}_shoulder", f"{side}_collar", _rest_vector(f"{side}_shoulder"), f"{side}_elbow"),
            (f"{side}_elbow", f"{side}_shoulder", _rest_vector(f"{side}_elbow"), f"{side}_wrist"),
            (f"{side}_wrist", f"{side}_elbow", _rest_vector(f"{side}_wrist"), None),
        ]
    return h


HIERARCHY = _hierarchy()


def _parent_bone_joint(name: str) -> str:
    """The skeleton joint at which the bone named ``name`` starts."""
    return dict((c, p) for p, c in BONES)[name]


def local_rotations(clip: MotionClip) -> np.ndarray:
    """Local rotation matrices (T, len(HIERARCHY), 3, 3) in HIERARCHY order."""
    pos = np.asarray(clip.positions, dtype=np.float64)
    T = pos.shape[0]
    out = np.zeros((T, len(HIERARCHY), 3, 3))
    for t in range(T):
        world: dict[str, np.ndarray] = {}
        for i, (joint, parent, _, bone) in enumerate(HIERARCHY):
            if bone is None:
                g = world[parent]
            else:
                start = pos[t, JOINT_INDEX[_parent_bone_joint(bone)]]
                end = pos[t, JOINT_INDEX[bone]]
                g = shortest_arc(REST_DIRECTIONS[bone], end - start)
            world[joint] = g
            out[t, i] = g if parent is None else world[parent].T @ g
    return out


def euler_zxy(rotations: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) -> intrinsic ZXY Euler angles (..., 3) in degrees."""
    from scipy.spatial.transform import Rotation

    shape = rotations.shape[:-2]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gimbal lock: still an exact decomposition
        e = Rotation.from_matrix(rotations.reshape(-1, 3, 3)).as_euler(EULER_ORDER, degrees=True)
    return e.reshape(*shape, 3)


def _fmt(v) -> str:
    return " ".join(f"{x:.6f}" for x in v)


def bvh_text(clip: MotionClip) -> str:
    """The BVH file for ``clip`` as text."""
    children: dict[str | None, list[int]] = {}
    for i, (_, parent, _, _) in enumerate(HIERARCHY):
        children.setdefault(parent, []).append(i)
    lines: list[str] = ["HIERARCHY"]

    def write(i: int, depth: int) -> None:
        joint, parent, offset, _ = HIERARCHY[i]
        pad = "  " * depth
        if parent is None:
            lines.append(f"ROOT {joint}")
        else:
            lines.append(f"{pad}JOINT {joint}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET {_fmt(offset)}")
        ch = ROOT_CHANNELS if parent is None else CHANNELS
        lines.append(f"{pad}  CHANNELS {len(ch)} {' '.join(ch)}")
        kids = children.get(joint, [])
        for k in kids:
            write(k, depth + 1)
        if not kids:
            bone = joint  # head_top / wrists: the end site continues the bone into them
            tip = np.asarray(REST_DIRECTIONS[bone]) * END_SITES[joint]
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            lines.append(f"{pad}    OFFSET {_fmt(tip)}")
            lines.append(f"{pad}  }}")
        lines.append(pad + "}")

    write(children[None][0], 0)
    rots = euler_zxy(local_rotations(clip))  # (T, J, 3), ZXY order
    root = np.asarray(clip.positions, dtype=np.float64)[:, JOINT_INDEX["spine"]]
    lines.append("MOTION")
    lines.append(f"Frames: {clip.n_frames}")
    lines.append(f"Frame Time: {1.0 / FPS:.7f}")
    for t in range(clip.n_frames):
        lines.append(_fmt(np.concatenate([root[t], rots[t].ravel()])))
    return "\n".join(lines) + "\n"


def csv_text(clip: MotionClip) -> str:
    """One row per frame: frame, time (s), then x, y, z of every joint in metres."""
    buf = io.StringIO()
    cols = ["frame", "time"] + [f"{j}_{a}" for j in JOINTS for a in "xyz"]
    buf.write(",".join(cols) + "\n")
    pos = np.asarray(clip.positions, dtype=np.float64).reshape(clip.n_frames, -1)
    for t in range(clip.n_frames):
        buf.write(f"{t},{t / FPS:.6f}," + ",".join(f"{x:.6f}" for x in pos[t]) + "\n")
    return buf.getvalue()


def write_bvh(path, clip: MotionClip) -> None:
    atomic_write(path, bvh_text(clip).encode("utf-8"))


def write_csv(path, clip: MotionClip) -> None:
    atomic_write(path, csv_text(clip).encode("utf-8"))

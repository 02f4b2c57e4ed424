"""Exports of motion clips: BVH (joint rotations) and CSV (joint positions).

BVH for any skeletal rig of :mod:`renders.rigs` (``rig``; sgt's own by default). sgt's own
hierarchy (all names are skeleton joint names except the two zero-length collars)::

    ROOT spine            6 channels: Xposition Yposition Zposition Zrotation Xrotation Yrotation
      neck                3 channels: Zrotation Xrotation Yrotation (every JOINT below too)
        nose
          head_top        End Site 0.05 m on along the head
        left_collar       OFFSET 0 0 0
          left_shoulder
            left_elbow
              left_wrist  the hand: left_thumb_cmc, left_index_mcp, ... (renders/rigs/sgt.py)
        right_collar      OFFSET 0 0 0
          right_shoulder ...

A joint's rotation turns the bone from it to its child: spine -> neck, neck -> nose,
nose -> head_top, left_collar -> left_shoulder, left_shoulder -> left_elbow,
left_elbow -> left_wrist; the wrist turns the hand and every finger joint the bone to the
next joint of its digit (aimed and rolled: :class:`renders.rigs.rig.AimRoll`). The collars exist because one BVH rotation can orient only one
bone, and the neck starts three. OFFSETs are the rig's rest-pose bone vectors (for sgt's rig
:data:`core.skeleton.REST_DIRECTIONS` times the bone lengths) in metres, so all-zero
rotations give the rig's rest pose (a T-pose for the VRM, Mixamo and SMPL-X rigs).

Roll: the skeleton stores bone directions only, so twist about a body bone is undefined. For
sgt's rig the world rotation of every body bone is the shortest-arc rotation from its rest
direction to its direction in the frame (no twist relative to the rest pose); hands and finger
bones take their roll from the hand (the knuckles' line); other rigs follow the
convention of :mod:`renders.rigs.rig`. BVH has no rest orientations: a joint's channels hold
its rotation relative to the rest pose, local rotations are parent^-1 * child of those. Euler
angles are intrinsic Z, X, Y in degrees (R = Rz Rx Ry, the order of the channels), and
continuous from frame to frame (:func:`unwrap_euler`): a channel may pass +-180 instead of
jumping by 360, so a client that interpolates channels linearly stays on the motion.
"""

from __future__ import annotations

import io
import warnings

import numpy as np

from core.fileio import atomic_write
from core.motion import MotionClip
from core.skeleton import FPS, JOINTS
from renders.rigs import SGT, Rig
from renders.rigs.retarget import retarget_clip

ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
EULER_ORDER = "ZXY"  # intrinsic: R = Rz @ Rx @ Ry


def local_rotations(clip: MotionClip, rig: Rig = SGT) -> np.ndarray:
    """BVH local rotation matrices (T, bones, 3, 3) in the rig's bone order."""
    delta = retarget_clip(rig, clip).world_delta()
    parents = rig.parent_indices()
    out = delta.copy()
    has = parents >= 0
    out[:, has] = np.swapaxes(delta[:, parents[has]], -1, -2) @ delta[:, has]
    return out


def euler_zxy(rotations: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) -> intrinsic ZXY Euler angles (..., 3) in degrees."""
    from scipy.spatial.transform import Rotation

    shape = rotations.shape[:-2]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gimbal lock: still an exact decomposition
        e = Rotation.from_matrix(rotations.reshape(-1, 3, 3)).as_euler(EULER_ORDER, degrees=True)
    return e.reshape(*shape, 3)


def unwrap_euler(angles: np.ndarray) -> np.ndarray:
    """Continuous intrinsic ZXY Euler angles (T, ..., 3) in degrees: the same rotations, but from
    one frame to the next each joint takes, of the two ZXY solutions ``(z, x, y)`` and
    ``(z + 180, 180 - x, y + 180)`` with any multiple of 360 added, the one nearest the previous
    frame. Clients that interpolate channels linearly then never swing through a wrap at +-180."""
    e = np.array(angles, dtype=np.float64)
    if len(e) < 2:
        return e
    alt = np.stack([e[..., 0] + 180.0, 180.0 - e[..., 1], e[..., 2] + 180.0], axis=-1)
    out = np.empty_like(e)
    out[0] = e[0]
    for t in range(1, len(e)):
        prev = out[t - 1]
        best = None
        for cand in (e[t], alt[t]):
            c = cand + 360.0 * np.round((prev - cand) / 360.0)
            d = np.abs(c - prev).sum(-1, keepdims=True)
            if best is None:
                best, best_d = c, d
            else:
                best = np.where(d < best_d, c, best)
                best_d = np.minimum(d, best_d)
        out[t] = best
    return out


def _fmt(v) -> str:
    return " ".join(f"{x:.6f}" for x in v)


def bvh_text(clip: MotionClip, rig: Rig = SGT) -> str:
    """The BVH file for ``clip`` on ``rig`` as text."""
    offsets = rig.rest_offsets()
    lines: list[str] = ["HIERARCHY"]
    order: list[int] = []  # MOTION columns follow the joints in the order the hierarchy lists them

    def write(i: int, depth: int) -> None:
        order.append(i)
        bone = rig.bones[i]
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if bone.parent is None else 'JOINT'} {bone.name}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET {_fmt(np.zeros(3) if bone.parent is None else offsets[i])}")
        ch = ROOT_CHANNELS if bone.parent is None else CHANNELS
        lines.append(f"{pad}  CHANNELS {len(ch)} {' '.join(ch)}")
        kids = [rig.index[k] for k in rig.children(bone.name)]
        for k in kids:
            write(k, depth + 1)
        if not kids:  # a leaf: the End Site continues the bone to its tail
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            lines.append(f"{pad}    OFFSET {_fmt(np.asarray(bone.tail) - np.asarray(bone.head))}")
            lines.append(f"{pad}  }}")
        lines.append(pad + "}")

    write(0, 0)
    motion = retarget_clip(rig, clip)
    rots = unwrap_euler(euler_zxy(local_rotations(clip, rig)))  # (T, J, 3), ZXY order, continuous
    root = motion.root_translation
    lines.append("MOTION")
    lines.append(f"Frames: {clip.n_frames}")
    lines.append(f"Frame Time: {1.0 / FPS:.7f}")
    rows = np.concatenate([root, rots[:, order].reshape(clip.n_frames, -1)], axis=1)
    lines.extend(_fmt(r) for r in rows)
    return "\n".join(lines) + "\n"


def csv_text(clip: MotionClip, utterances=None) -> str:
    """One row per frame: frame, time (s), the utterance playing (its number; empty between
    utterances), then x, y, z of every joint in metres. ``utterances``: the per-frame numbers
    (:func:`renders.clips.utterance_frames`); None: the clip is one utterance, number 0."""
    buf = io.StringIO()
    cols = ["frame", "time", "utterance"] + [f"{j}_{a}" for j in JOINTS for a in "xyz"]
    buf.write(",".join(cols) + "\n")
    pos = np.asarray(clip.positions, dtype=np.float64).reshape(clip.n_frames, -1)
    if utterances is None:
        utterances = [0] * clip.n_frames
    for t in range(clip.n_frames):
        u = utterances[t]
        buf.write(f"{t},{t / FPS:.6f},{'' if u is None else u}," + ",".join(f"{x:.6f}" for x in pos[t]) + "\n")
    return buf.getvalue()


def write_bvh(path, clip: MotionClip, rig: Rig = SGT) -> None:
    atomic_write(path, bvh_text(clip, rig).encode("utf-8"))


def write_csv(path, clip: MotionClip, utterances=None) -> None:
    atomic_write(path, csv_text(clip, utterances).encode("utf-8"))

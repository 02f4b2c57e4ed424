"""The skeleton, the motion representation and the frame rate: the one place that owns them.

Every other module imports these names instead of redefining them.

Skeleton (SGToolkit appendix A.2): 10 upper-body joints joined by 9 bones of fixed length.
A *pose* is stored as the 9 bone directions (unit vectors, parent -> child), flattened to
27 numbers in the order of :data:`BONES`. A *motion* is an array of poses, shape (T, 27),
sampled at :data:`FPS` frames per second.

Coordinates in every public file: y up, right-handed, metres. The character stands at the
origin facing +z (towards the viewer), so its **left** hand is on **+x**.
"""

from __future__ import annotations

import math

import numpy as np

#: Frames per second of every motion, control array and plan.
FPS = 15

#: Joint names, in array order. Files always name joints; indices are for arrays only.
JOINTS: tuple[str, ...] = (
    "spine",
    "neck",
    "nose",
    "head_top",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
)
JOINT_INDEX = {name: i for i, name in enumerate(JOINTS)}

#: Bones as (parent, child) joint names; a bone is named after its child joint.
BONES: tuple[tuple[str, str], ...] = (
    ("spine", "neck"),
    ("neck", "nose"),
    ("nose", "head_top"),
    ("neck", "left_shoulder"),
    ("left_shoulder", "left_elbow"),
    ("left_elbow", "left_wrist"),
    ("neck", "right_shoulder"),
    ("right_shoulder", "right_elbow"),
    ("right_elbow", "right_wrist"),
)
BONE_NAMES: tuple[str, ...] = tuple(child for _, child in BONES)
BONE_INDEX = {name: i for i, name in enumerate(BONE_NAMES)}

#: Bone lengths in metres, by bone (child joint) name.
BONE_LENGTHS: dict[str, float] = {
    "neck": 0.42,
    "nose": 0.20,
    "head_top": 0.14,
    "left_shoulder": 0.18,
    "left_elbow": 0.29,
    "left_wrist": 0.26,
    "right_shoulder": 0.18,
    "right_elbow": 0.29,
    "right_wrist": 0.26,
}
BONE_LENGTH_ARRAY = np.array([BONE_LENGTHS[b] for b in BONE_NAMES], dtype=np.float64)

#: Where the root joint (spine) stands, in metres.
ROOT_POSITION = np.array([0.0, 1.0, 0.0])

N_JOINTS = len(JOINTS)
N_BONES = len(BONES)
POSE_DIM = 3 * N_BONES  # 27

_PARENT_INDEX = np.array([JOINT_INDEX[p] for p, _ in BONES])
_CHILD_INDEX = np.array([JOINT_INDEX[c] for _, c in BONES])


def mirror_name(name: str) -> str:
    """The name of the joint or bone on the other side ("left_wrist" <-> "right_wrist"); others unchanged."""
    if name.startswith("left_"):
        return "right_" + name[5:]
    if name.startswith("right_"):
        return "left_" + name[6:]
    return name


#: For bone i of a mirrored pose, the index of the bone it is copied from.
MIRROR_BONE_PERMUTATION = np.array([BONE_INDEX[mirror_name(b)] for b in BONE_NAMES])


def _unit(v) -> list[float]:
    v = np.asarray(v, dtype=np.float64)
    return list(v / np.linalg.norm(v))


#: The rest pose: upright, arms hanging relaxed with the forearms a little forward.
REST_DIRECTIONS: dict[str, list[float]] = {
    "neck": _unit([0.0, 1.0, 0.0]),
    "nose": _unit([0.0, 0.78, 0.62]),
    "head_top": _unit([0.0, 0.9, -0.42]),
    "left_shoulder": _unit([1.0, 0.0, 0.0]),
    "left_elbow": _unit([0.12, -1.0, 0.02]),
    "left_wrist": _unit([0.02, -0.75, 0.66]),
    "right_shoulder": _unit([-1.0, 0.0, 0.0]),
    "right_elbow": _unit([-0.12, -1.0, 0.02]),
    "right_wrist": _unit([-0.02, -0.75, 0.66]),
}
REST_POSE = np.concatenate([REST_DIRECTIONS[b] for b in BONE_NAMES]).astype(np.float32)


def seconds_to_frame(seconds: float) -> int:
    """The frame that contains time ``seconds`` (frame i covers [i/FPS, (i+1)/FPS))."""
    return int(math.floor(seconds * FPS + 1e-6))


def frame_count(duration: float) -> int:
    """Number of frames needed to cover ``duration`` seconds (at least 1)."""
    return max(1, int(math.ceil(duration * FPS - 1e-6)))


def normalize_pose(poses: np.ndarray) -> np.ndarray:
    """Rescale every bone direction of ``poses`` (..., 27) to unit length."""
    p = np.asarray(poses, dtype=np.float32).reshape(*np.shape(poses)[:-1], N_BONES, 3)
    n = np.linalg.norm(p, axis=-1, keepdims=True)
    p = p / np.maximum(n, 1e-8)
    return p.reshape(*p.shape[:-2], POSE_DIM)


def slerp_poses(a: np.ndarray, b: np.ndarray, w) -> np.ndarray:
    """Poses ``a`` -> ``b`` (n, 27) by weight ``w`` (n,): every bone direction turns along the
    great circle (slerp), so even a bone turned round by 180 degrees moves smoothly (opposite
    directions turn about the perpendicular nearest the x axis). float32."""
    w = np.asarray(w, np.float64).reshape(-1)
    n = len(w)
    a = normalize_pose(np.asarray(a, np.float64)).reshape(n, N_BONES, 3).astype(np.float64)
    b = normalize_pose(np.asarray(b, np.float64)).reshape(n, N_BONES, 3).astype(np.float64)
    dot = np.clip((a * b).sum(-1, keepdims=True), -1.0, 1.0)
    ortho = b - dot * a
    norm = np.linalg.norm(ortho, axis=-1, keepdims=True)
    side = np.cross(a, np.cross(np.array([1.0, 0.0, 0.0]), a))
    side = np.where(np.linalg.norm(side, axis=-1, keepdims=True) < 1e-6, np.cross(a, [0.0, 0.0, 1.0]), side)
    ortho = np.where(norm < 1e-6, side, ortho)
    ortho /= np.linalg.norm(ortho, axis=-1, keepdims=True)
    angle = np.arccos(dot) * w[:, None, None]
    return normalize_pose((np.cos(angle) * a + np.sin(angle) * ortho).reshape(n, -1))


def bone_angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Degrees between the bone directions of poses ``a`` and ``b`` (..., 27) -> (..., 9)."""
    a = np.asarray(a, np.float64).reshape(*np.shape(a)[:-1], N_BONES, 3)
    b = np.asarray(b, np.float64).reshape(*np.shape(b)[:-1], N_BONES, 3)
    cos = (a * b).sum(-1) / np.maximum(np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1), 1e-12)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def positions_from_pose(poses: np.ndarray, root=ROOT_POSITION) -> np.ndarray:
    """Forward kinematics: poses (..., 27) -> joint positions (..., 10, 3) in metres."""
    p = np.asarray(poses, dtype=np.float64)
    dirs = p.reshape(*p.shape[:-1], N_BONES, 3)
    out = np.zeros((*p.shape[:-1], N_JOINTS, 3), dtype=np.float64)
    out[..., JOINT_INDEX["spine"], :] = root
    # BONES is ordered so that every parent is placed before its children.
    for i in range(N_BONES):
        out[..., _CHILD_INDEX[i], :] = (
            out[..., _PARENT_INDEX[i], :] + dirs[..., i, :] * BONE_LENGTH_ARRAY[i]
        )
    return out


def pose_from_positions(positions: np.ndarray) -> np.ndarray:
    """Joint positions (..., 10, 3) -> poses (..., 27) of unit bone directions.

    Bone lengths in the input may differ from the skeleton's; only directions are kept.
    """
    x = np.asarray(positions, dtype=np.float64)
    d = x[..., _CHILD_INDEX, :] - x[..., _PARENT_INDEX, :]
    return normalize_pose(d.reshape(*d.shape[:-2], POSE_DIM))


def mirror_pose(poses: np.ndarray) -> np.ndarray:
    """Mirror left and right: swap left/right bones and negate x. Mirroring twice is identity."""
    p = np.asarray(poses)
    dirs = p.reshape(*p.shape[:-1], N_BONES, 3)[..., MIRROR_BONE_PERMUTATION, :].copy()
    dirs[..., 0] = -dirs[..., 0]
    return dirs.reshape(p.shape)

"""Retargeting: source joint positions (sgt's skeleton) -> a rig's bone rotations per frame.

See :mod:`renders.rigs.rig` for the drives and the twist convention. All frames at once (numpy,
no Python loop over frames), so a 10-minute take takes well under a second per rig.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.hands import HAND_JOINTS, SIDES, hand_positions
from core.motion import MotionClip
from core.skeleton import BONE_NAMES, JOINTS, REST_DIRECTIONS, positions_from_pose
from renders.rigs.rig import Aim, AimRoll, Orient, Rig, roll_direction
from renders.rotations import axis_rotations, matrix_to_quat, shortest_arcs, triads


@dataclass
class RigMotion:
    """A rig's motion: world and local bone rotations (T, B, 3, 3), the root's translation
    (T, 3) (its head's world position), all in the rig's bone order."""

    rig: Rig
    world: np.ndarray
    local: np.ndarray
    root_translation: np.ndarray

    @property
    def n_frames(self) -> int:
        return int(self.world.shape[0])

    def world_delta(self) -> np.ndarray:
        """World rotations relative to the rest pose (T, B, 3, 3): what BVH stores."""
        r0 = self.rig.rest_rotations()
        return self.world @ np.swapaxes(r0, -1, -2)[None]

    def joint_positions(self) -> np.ndarray:
        """Forward kinematics of the rig: bone head positions (T, B, 3), metres."""
        p = self.rig.parent_indices()
        offsets = self.rig.rest_offsets()
        delta = self.world_delta()
        out = np.zeros((self.n_frames, len(p), 3))
        out[:, 0] = self.root_translation
        for i in range(1, len(p)):
            out[:, i] = out[:, p[i]] + delta[:, p[i]] @ offsets[i]
        return out


def source_positions(clip: MotionClip) -> dict[str, np.ndarray]:
    """The source joints of a clip by name: (T, 3) arrays, metres: the skeleton's joints and
    the hands' (``left_index_mcp``, ..., :data:`core.hands.HAND_JOINTS` per side)."""
    pos = np.asarray(clip.positions, dtype=np.float64)
    out = {name: pos[:, i] for i, name in enumerate(JOINTS)}
    hands = hand_positions(pos, clip.hands)
    for s, side in enumerate(SIDES):
        for k, name in enumerate(HAND_JOINTS):
            out[f"{side}_{name}"] = hands[:, s, k]
    return out


def source_rest() -> dict[str, np.ndarray]:
    """The source skeleton's rest pose by joint name ((3,) arrays)."""
    pos = positions_from_pose(np.concatenate([REST_DIRECTIONS[b] for b in BONE_NAMES]))
    return {name: pos[i] for i, name in enumerate(JOINTS)}


def _seg(joints: dict[str, np.ndarray], pair: tuple[str, str]) -> np.ndarray:
    return joints[pair[1]] - joints[pair[0]]


_REFERENCES = (np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))


def rest_alignment(rig_aim: np.ndarray, source_aim: np.ndarray) -> np.ndarray:
    """The rotation that carries a bone from its rig rest aim to the source's rest direction
    keeping its front in front: the plane through the bone and the forward axis (+z; +x for a
    bone that points forward or back) maps to the same plane through the source direction. So
    the rig's rest pose (T-pose, A-pose) changes where a bone starts, never its twist."""
    a = rig_aim / np.linalg.norm(rig_aim)
    b = source_aim / np.linalg.norm(source_aim)
    for ref in _REFERENCES:
        if min(np.linalg.norm(np.cross(a, ref)), np.linalg.norm(np.cross(b, ref))) > 0.3:
            return triads(b, ref) @ triads(a, ref).T
    return shortest_arcs(a, b)


def retarget(rig: Rig, joints: dict[str, np.ndarray], rest: dict[str, np.ndarray] | None = None) -> RigMotion:
    """Bone rotations of ``rig`` following source joint positions ``joints`` (name -> (T, 3)).

    ``rest`` is the source's rest pose (name -> (3,)); sgt's skeleton rest pose by default.
    """
    rest = source_rest() if rest is None else rest
    missing = sorted(rig.source_joints() - set(joints))
    if missing:
        raise ValueError(f"rig {rig.name} needs source joints {', '.join(missing)}")
    T = len(joints[rig.root_source])
    r0 = rig.rest_rotations()
    heads = rig.heads()
    parents = rig.parent_indices()
    world = np.zeros((T, len(rig.bones), 3, 3))
    for i, bone in enumerate(rig.bones):
        d = bone.drive
        if isinstance(d, Aim):
            src_rest = _seg(rest, d.source)
            align = rest_alignment(rig.aim_end(bone) - heads[i], src_rest)  # rig rest -> source rest
            world[:, i] = shortest_arcs(src_rest, _seg(joints, d.source)) @ align @ r0[i]
        elif isinstance(d, AimRoll):
            f_rig = triads(rig.aim_end(bone) - heads[i], rig.rest_roll(bone))
            f_now = triads(_seg(joints, d.source), roll_direction(joints, d.roll))
            world[:, i] = f_now @ f_rig.T @ r0[i]
        elif isinstance(d, Orient):
            f_rest = triads(_seg(rest, d.primary), _seg(rest, d.secondary))
            f_now = triads(_seg(joints, d.primary), _seg(joints, d.secondary))
            world[:, i] = f_now @ f_rest.T @ r0[i]
        elif parents[i] < 0:
            world[:, i] = r0[i]
        else:  # follows its parent: keeps its rest rotation relative to it
            p = parents[i]
            world[:, i] = world[:, p] @ (r0[p].T @ r0[i])
    for i, bone in enumerate(rig.bones):
        p = parents[i]
        if isinstance(bone.drive, AimRoll) and p >= 0 and isinstance(rig.bones[p].drive, Aim) and parents[p] >= 0:
            _share_twist(rig, world, r0, heads, hand=i, forearm=p, upper=parents[p])
    local = world.copy()
    has_parent = parents >= 0
    local[:, has_parent] = np.swapaxes(world[:, parents[has_parent]], -1, -2) @ world[:, has_parent]
    root = heads[0] + rig.translation_scale * (joints[rig.root_source] - rest[rig.root_source])
    return RigMotion(rig=rig, world=world, local=local, root_translation=root)


def _share_twist(rig: Rig, world: np.ndarray, r0: np.ndarray, heads: np.ndarray, *, hand: int, forearm: int,
                 upper: int) -> None:
    """Spread the hand's turn about the forearm over the elbow and the wrist (``world`` is
    changed in place, the forearm's rotations only; every bone keeps its aim, every joint its
    place).

    Aimed by the least rotation from its rest direction, a forearm keeps whatever twist that
    rotation happens to have, so the elbow carried up to 179 degrees of twist and the wrist
    all of the hand's pronation, up to 180 degrees: a candy-wrapper on a skinned character.
    Here (a swing-twist decomposition) the forearm first turns relative to the upper arm by
    the least rotation that aims it (an elbow with no twist of its own), then takes half of
    the hand's remaining twist about the forearm's axis, unwrapped over the frames so that it
    never jumps (:func:`_unwrap_within_runs`): the elbow and the wrist each carry half of the
    pronation, at most 90 degrees for a hand turned round."""
    aim = rig.aim_end(rig.bones[forearm]) - heads[forearm]
    axis = r0[forearm].T @ (aim / np.linalg.norm(aim))  # the forearm's aim in its own frame
    rest_local = r0[upper].T @ r0[forearm]
    base = world[:, upper] @ rest_local  # (T, 3, 3): the forearm's rest relation to the upper arm, now
    now = np.einsum("tji,tj->ti", base, world[:, forearm] @ axis)  # its aim in that frame
    world[:, forearm] = base @ shortest_arcs(axis, now)
    # the hand's rotation relative to its rest relation to the forearm, in the forearm's frame
    dev = np.swapaxes(world[:, forearm], -1, -2) @ world[:, hand] @ (r0[hand].T @ r0[forearm])
    q = matrix_to_quat(dev)
    twist = _unwrap_within_runs(2.0 * np.arctan2(q[:, :3] @ axis, q[:, 3]))
    world[:, forearm] = world[:, forearm] @ axis_rotations(axis, twist / 2.0)


def _unwrap_within_runs(angles: np.ndarray, cut: float = 2.0 * np.pi / 3.0) -> np.ndarray:
    """Angles (T,) radians made continuous, in runs split where one frame moves them by
    ``cut`` or more (a cut in the motion, or a turn no arm makes in a frame), each run then
    moved by whole turns so that its median lies in (-pi, pi]: continuous where the motion is,
    and never a whole turn off where it is not."""
    wrapped = np.angle(np.exp(1j * angles))
    if len(wrapped) < 2:
        return wrapped
    steps = np.angle(np.exp(1j * np.diff(wrapped)))
    out = np.concatenate([[wrapped[0]], wrapped[0] + np.cumsum(steps)])
    starts = np.concatenate([[0], np.flatnonzero(np.abs(steps) >= cut) + 1, [len(out)]])
    for a, b in zip(starts[:-1], starts[1:]):
        run = out[a:b]
        out[a:b] = run - 2.0 * np.pi * np.round(np.median(run) / (2.0 * np.pi))
    return out


def retarget_clip(rig: Rig, clip: MotionClip) -> RigMotion:
    return retarget(rig, source_positions(clip))

"""Finger bones for any rig: the hand bone's drive and the thumb's and fingers' bones.

Every rig's hand turns with sgt's hand (aimed at the middle finger's knuckle, rolled by the
line of the knuckles) and every finger bone is aimed along its sgt segment and rolled with the
knuckles' line (the thumb with the palm's normal): :class:`renders.rigs.rig.AimRoll`, so the
rig's rest hand (relaxed and hanging for sgt, flat in a T-pose for VRM, Mixamo and SMPL-X)
does not matter.
"""

from __future__ import annotations

import numpy as np

from core.hands import DIGITS, HAND_JOINTS, local_hand_joints
from renders.rigs.rig import AimRoll, Bone

#: A flat hand for T-pose rigs: straight fingers, the thumb 40 degrees out from the index.
FLAT = np.zeros((5, 4))
FLAT[0, 0] = 40.0


def hand_bones(side: str, parent: str, head: dict[str, tuple], name) -> list[Bone]:
    """The finger bones of one hand for a rig: ``head`` gives each hand joint's rest position by
    its sgt name (``index_mcp``, ..., tips included) and ``name`` the rig's bone name for an sgt
    hand joint name (tips excluded). The fingers roll with the knuckles' line, the thumb with
    the palm's normal."""
    across = (f"{side}_little_mcp", f"{side}_index_mcp")
    normal = across + (f"{side}_wrist", f"{side}_middle_mcp")
    rig_across = (name("little_mcp"), name("index_mcp"))
    rig_normal = rig_across + (parent, name("middle_mcp"))
    bones = []
    for d, digit in enumerate(DIGITS):
        chain = HAND_JOINTS[4 * d : 4 * d + 4]
        roll, rig_roll = (normal, rig_normal) if digit == "thumb" else (across, rig_across)
        for k in range(3):
            a, b = chain[k], chain[k + 1]
            leaf = k == 2
            drive = AimRoll((f"{side}_{a}", f"{side}_{b}"), roll, rig_roll, None if leaf else name(b))
            bones.append(Bone(name(a), parent if k == 0 else name(chain[k - 1]), head[a], drive,
                              head[b] if leaf else None))
    return bones


def wrist_drive(side: str, name) -> AimRoll:
    """The hand bone: aimed at the middle finger's knuckle, rolled by the knuckles' line."""
    return AimRoll((f"{side}_wrist", f"{side}_middle_mcp"), (f"{side}_little_mcp", f"{side}_index_mcp"),
                   (name("little_mcp"), name("index_mcp")), name("middle_mcp"))


def t_pose_hand(side: str, wrist, scale: float = 1.0) -> dict[str, tuple[float, float, float]]:
    """Rest positions of the hand joints (sgt names) of a flat T-pose hand at ``wrist``: fingers
    along the arm (+x for the left hand, -x for the right), palm down, thumb forward (+z)."""
    along = np.array([1.0 if side == "left" else -1.0, 0.0, 0.0])
    thumb, palm = np.array([0.0, 0.0, 1.0]), np.array([0.0, -1.0, 0.0])
    local = local_hand_joints(FLAT) * scale
    w = np.asarray(wrist, dtype=np.float64)
    return {j: tuple(w + local[k, 0] * thumb + local[k, 1] * along + local[k, 2] * palm)
            for k, j in enumerate(HAND_JOINTS)}

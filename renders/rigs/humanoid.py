"""The humanoid rigs: VRM humanoid bone names and Mixamo's, on one T-pose skeleton.

Rest pose: a generic adult about 1.78 m tall in a T-pose (arms straight out along +-x, palms
down), standing on y = 0, facing +z, all rest rotations identity: the pose VRM 1.0 requires of
a VRM Animation's humanoid ("VRM T-pose") and the pose Mixamo's skeletons bind in. Proportions
are typical adult ones (hips at 1.00 m, shoulders at 1.44 m), not any one character's: the
rotations a player applies do not depend on them, only the hips translation (scaled, see
``translation_scale``).

Legs and feet are there because humanoid importers (Unity's Humanoid, VRM) require them; they
keep their rest pose. Hands and fingers follow sgt's hands (:mod:`renders.rigs.hands`): a flat
T-pose hand at rest (fingers along the arm, palm down, thumb 40 degrees forward), VRM 1.0's
finger bones (``leftThumbMetacarpal`` .. ``leftLittleDistal``) and Mixamo's
(``mixamorig:LeftHandThumb1`` .. ``LeftHandPinky3``).
"""

from __future__ import annotations

import numpy as np

from core.skeleton import BONE_LENGTHS
from renders.rigs.hands import hand_bones, t_pose_hand, wrist_drive
from renders.rigs.rig import Aim, AimRoll, Bone, Orient, Rig

#: sgt's hand joint (the head of a finger bone) -> the VRM 1.0 finger bone name (after the side).
_VRM_FINGERS = {"thumb_cmc": "ThumbMetacarpal", "thumb_mcp": "ThumbProximal", "thumb_ip": "ThumbDistal"}
for _d, _vrm in (("index", "Index"), ("middle", "Middle"), ("ring", "Ring"), ("little", "Little")):
    _VRM_FINGERS.update({f"{_d}_mcp": f"{_vrm}Proximal", f"{_d}_pip": f"{_vrm}Intermediate", f"{_d}_dip": f"{_vrm}Distal"})


def _vrm_finger(side: str, joint: str) -> str:
    return side + _VRM_FINGERS[joint]


SPINE = Orient(("spine", "neck"), ("right_shoulder", "left_shoulder"))
HEAD = Orient(("neck", "head_top"), ("neck", "nose"))

# (VRM humanoid name, parent, head position (m), drive, tail)
_TABLE: list[tuple[str, str | None, tuple[float, float, float], object, tuple | None]] = [
    ("hips", None, (0.0, 1.00, 0.0), None, None),
    ("spine", "hips", (0.0, 1.10, 0.0), SPINE, None),
    ("chest", "spine", (0.0, 1.22, 0.0), None, None),
    ("upperChest", "chest", (0.0, 1.35, 0.0), None, None),
    ("neck", "upperChest", (0.0, 1.50, 0.0), None, None),
    ("head", "neck", (0.0, 1.60, 0.01), HEAD, (0.0, 1.78, 0.01)),
]
for _side, _x in (("left", 1.0), ("right", -1.0)):
    _s = _side.capitalize()
    _TABLE += [
        (f"{_side}Shoulder", "upperChest", (0.05 * _x, 1.44, 0.0), Aim(("neck", f"{_side}_shoulder"), f"{_side}UpperArm"), None),
        (f"{_side}UpperArm", f"{_side}Shoulder", (0.18 * _x, 1.44, 0.0),
         Aim((f"{_side}_shoulder", f"{_side}_elbow"), f"{_side}LowerArm"), None),
        (f"{_side}LowerArm", f"{_side}UpperArm", (0.45 * _x, 1.44, 0.0),
         Aim((f"{_side}_elbow", f"{_side}_wrist"), f"{_side}Hand"), None),
        (f"{_side}Hand", f"{_side}LowerArm", (0.70 * _x, 1.44, 0.0), wrist_drive(_side, lambda j, s=_side: _vrm_finger(s, j)),
         None),
        (f"{_side}UpperLeg", "hips", (0.09 * _x, 0.95, 0.0), None, None),
        (f"{_side}LowerLeg", f"{_side}UpperLeg", (0.09 * _x, 0.52, 0.0), None, None),
        (f"{_side}Foot", f"{_side}LowerLeg", (0.09 * _x, 0.08, 0.0), None, None),
        (f"{_side}Toes", f"{_side}Foot", (0.09 * _x, 0.0, 0.12), None, (0.09 * _x, 0.0, 0.20)),
    ]

    _TABLE += [(b.name, b.parent, b.head, b.drive, b.tail)
               for b in hand_bones(_side, f"{_side}Hand", t_pose_hand(_side, (0.70 * _x, 1.44, 0.0)),
                                   lambda j, s=_side: _vrm_finger(s, j))]

#: VRM humanoid bone name -> Mixamo bone name (without the "mixamorig:" prefix).
MIXAMO_NAMES = {
    "hips": "Hips", "spine": "Spine", "chest": "Spine1", "upperChest": "Spine2", "neck": "Neck", "head": "Head",
    "leftShoulder": "LeftShoulder", "leftUpperArm": "LeftArm", "leftLowerArm": "LeftForeArm", "leftHand": "LeftHand",
    "rightShoulder": "RightShoulder", "rightUpperArm": "RightArm", "rightLowerArm": "RightForeArm",
    "rightHand": "RightHand",
    "leftUpperLeg": "LeftUpLeg", "leftLowerLeg": "LeftLeg", "leftFoot": "LeftFoot", "leftToes": "LeftToeBase",
    "rightUpperLeg": "RightUpLeg", "rightLowerLeg": "RightLeg", "rightFoot": "RightFoot", "rightToes": "RightToeBase",
}
_MIXAMO_FINGERS = {"thumb_cmc": "Thumb1", "thumb_mcp": "Thumb2", "thumb_ip": "Thumb3"}
for _d, _m in (("index", "Index"), ("middle", "Middle"), ("ring", "Ring"), ("little", "Pinky")):
    _MIXAMO_FINGERS.update({f"{_d}_mcp": f"{_m}1", f"{_d}_pip": f"{_m}2", f"{_d}_dip": f"{_m}3"})
for _side in ("left", "right"):
    for _joint, _vrm in _VRM_FINGERS.items():
        MIXAMO_NAMES[_side + _vrm] = f"{_side.capitalize()}Hand{_MIXAMO_FINGERS[_joint]}"
MIXAMO_PREFIX = "mixamorig:"


def _torso_scale(table) -> float:
    """Target hips->neck length over sgt's spine->neck length: the hips translation factor."""
    heads = {name: np.asarray(head) for name, _, head, _, _ in table}
    return float(np.linalg.norm(heads["neck"] - heads["hips"]) / BONE_LENGTHS["neck"])


def _rig(name: str, title: str, rename, vrm: bool) -> Rig:
    def drive(d):
        if isinstance(d, Aim) and d.to is not None:
            return Aim(d.source, rename(d.to))
        if isinstance(d, AimRoll):
            return AimRoll(d.source, d.roll, tuple(rename(n) for n in d.rig_roll), d.to and rename(d.to))
        return d

    bones = tuple(
        Bone(rename(n), None if p is None else rename(p), head, drive(d), tail, humanoid=n)
        for n, p, head, d, tail in _TABLE
    )
    return Rig(name=name, title=title, bones=bones, translation_scale=_torso_scale(_TABLE), vrm_animation=vrm)


VRM = _rig("vrm", "VRM humanoid (VRM 1.0 bone names, T-pose)", lambda n: n, vrm=True)
MIXAMO = _rig("mixamo", "Mixamo (mixamorig: names, T-pose)", lambda n: MIXAMO_PREFIX + MIXAMO_NAMES[n], vrm=False)

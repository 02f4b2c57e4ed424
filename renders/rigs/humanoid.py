"""The humanoid rigs: VRM humanoid bone names and Mixamo's, on one T-pose skeleton.

Rest pose: a generic adult about 1.78 m tall in a T-pose (arms straight out along +-x, palms
down), standing on y = 0, facing +z, all rest rotations identity: the pose VRM 1.0 requires of
a VRM Animation's humanoid ("VRM T-pose") and the pose Mixamo's skeletons bind in. Proportions
are typical adult ones (hips at 1.00 m, shoulders at 1.44 m), not any one character's: the
rotations a player applies do not depend on them, only the hips translation (scaled, see
``translation_scale``).

Legs and feet are there because humanoid importers (Unity's Humanoid, VRM) require them; they
keep their rest pose. Hands follow the forearms until sgt has hands: finger bones are then new
rows here driven by the new source joints.
"""

from __future__ import annotations

import numpy as np

from core.skeleton import BONE_LENGTHS
from renders.rigs.rig import Aim, Bone, Orient, Rig

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
        (f"{_side}Hand", f"{_side}LowerArm", (0.70 * _x, 1.44, 0.0), None, (0.88 * _x, 1.44, 0.0)),
        (f"{_side}UpperLeg", "hips", (0.09 * _x, 0.95, 0.0), None, None),
        (f"{_side}LowerLeg", f"{_side}UpperLeg", (0.09 * _x, 0.52, 0.0), None, None),
        (f"{_side}Foot", f"{_side}LowerLeg", (0.09 * _x, 0.08, 0.0), None, None),
        (f"{_side}Toes", f"{_side}Foot", (0.09 * _x, 0.0, 0.12), None, (0.09 * _x, 0.0, 0.20)),
    ]

#: VRM humanoid bone name -> Mixamo bone name (without the "mixamorig:" prefix).
MIXAMO_NAMES = {
    "hips": "Hips", "spine": "Spine", "chest": "Spine1", "upperChest": "Spine2", "neck": "Neck", "head": "Head",
    "leftShoulder": "LeftShoulder", "leftUpperArm": "LeftArm", "leftLowerArm": "LeftForeArm", "leftHand": "LeftHand",
    "rightShoulder": "RightShoulder", "rightUpperArm": "RightArm", "rightLowerArm": "RightForeArm",
    "rightHand": "RightHand",
    "leftUpperLeg": "LeftUpLeg", "leftLowerLeg": "LeftLeg", "leftFoot": "LeftFoot", "leftToes": "LeftToeBase",
    "rightUpperLeg": "RightUpLeg", "rightLowerLeg": "RightLeg", "rightFoot": "RightFoot", "rightToes": "RightToeBase",
}
MIXAMO_PREFIX = "mixamorig:"


def _torso_scale(table) -> float:
    """Target hips->neck length over sgt's spine->neck length: the hips translation factor."""
    heads = {name: np.asarray(head) for name, _, head, _, _ in table}
    return float(np.linalg.norm(heads["neck"] - heads["hips"]) / BONE_LENGTHS["neck"])


def _rig(name: str, title: str, rename, vrm: bool) -> Rig:
    def drive(d):
        if isinstance(d, Aim) and d.to is not None:
            return Aim(d.source, rename(d.to))
        return d

    bones = tuple(
        Bone(rename(n), None if p is None else rename(p), head, drive(d), tail, humanoid=n)
        for n, p, head, d, tail in _TABLE
    )
    return Rig(name=name, title=title, bones=bones, translation_scale=_torso_scale(_TABLE), vrm_animation=vrm)


VRM = _rig("vrm", "VRM humanoid (VRM 1.0 bone names, T-pose)", lambda n: n, vrm=True)
MIXAMO = _rig("mixamo", "Mixamo (mixamorig: names, T-pose)", lambda n: MIXAMO_PREFIX + MIXAMO_NAMES[n], vrm=False)

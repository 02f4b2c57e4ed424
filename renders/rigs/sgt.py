"""sgt's own rig: the skeleton's joint names and rest pose (the BVH hierarchy sgt always wrote).

Two zero-length collars start the shoulders (one rotation can orient only one bone, and three
bones start at the neck); head_top and the wrists end in tails 0.05 m and 0.08 m on.
"""

from __future__ import annotations

import numpy as np

from core.skeleton import BONE_LENGTHS, REST_DIRECTIONS, ROOT_POSITION
from renders.rigs.rig import Aim, Bone, Rig

TAILS = {"head_top": 0.05, "left_wrist": 0.08, "right_wrist": 0.08}


def _build() -> Rig:
    pos: dict[str, np.ndarray] = {"spine": np.asarray(ROOT_POSITION, dtype=np.float64)}

    def place(joint: str, parent: str) -> tuple[float, float, float]:
        pos[joint] = pos[parent] + np.asarray(REST_DIRECTIONS[joint]) * BONE_LENGTHS[joint]
        return tuple(pos[joint])

    def tail(joint: str) -> tuple[float, float, float]:
        return tuple(pos[joint] + np.asarray(REST_DIRECTIONS[joint]) * TAILS[joint])

    bones = [Bone("spine", None, tuple(pos["spine"]), Aim(("spine", "neck"), "neck"))]
    bones.append(Bone("neck", "spine", place("neck", "spine"), Aim(("neck", "nose"), "nose")))
    bones.append(Bone("nose", "neck", place("nose", "neck"), Aim(("nose", "head_top"), "head_top")))
    bones.append(Bone("head_top", "nose", place("head_top", "nose"), None, tail("head_top")))
    for side in ("left", "right"):
        s, e, w = f"{side}_shoulder", f"{side}_elbow", f"{side}_wrist"
        bones.append(Bone(f"{side}_collar", "neck", tuple(pos["neck"]), Aim(("neck", s), s)))
        bones.append(Bone(s, f"{side}_collar", place(s, "neck"), Aim((s, e), e)))
        bones.append(Bone(e, s, place(e, s), Aim((e, w), w)))
        bones.append(Bone(w, e, place(w, e), None, tail(w)))
    return Rig(name="sgt", title="sgt's own skeleton", bones=tuple(bones))


RIG = _build()

"""sgt's own rig: the skeleton's joint names and rest pose (the BVH hierarchy sgt always wrote),
and the hands' joints (:mod:`core.hands`) under the wrists.

Two zero-length collars start the shoulders (one rotation can orient only one bone, and three
bones start at the neck); head_top ends in a tail 0.05 m on. Each wrist turns with the hand
(aimed at the middle finger's knuckle, rolled by the knuckles' line) and carries the thumb
(``left_thumb_cmc`` -> ``_mcp`` -> ``_ip``) and the four fingers (``left_index_mcp`` -> ``_pip``
-> ``_dip``), each bone named after its head joint and ending at the next; the last ends at
the tip. Rest: sgt's rest pose with relaxed hands, palms in.
"""

from __future__ import annotations

import numpy as np

from core.hands import HAND_JOINTS, SIDES, HandTrack, hand_positions
from core.skeleton import BONE_LENGTHS, JOINTS, REST_DIRECTIONS, ROOT_POSITION
from renders.rigs.hands import hand_bones, wrist_drive
from renders.rigs.rig import Aim, Bone, Rig

TAILS = {"head_top": 0.05}


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
        place(w, e)
    body = np.stack([pos[j] for j in JOINTS])
    hands = hand_positions(body[None], HandTrack.rest(1))[0]
    for s_, side in enumerate(SIDES):
        e, w = f"{side}_elbow", f"{side}_wrist"
        head = {j: tuple(hands[s_, k]) for k, j in enumerate(HAND_JOINTS)}
        name = lambda j, side=side: f"{side}_{j}"  # noqa: E731 - sgt's bones are its joint names
        at = next(i for i, b in enumerate(bones) if b.name == e) + 1
        bones[at:at] = [Bone(w, e, tuple(pos[w]), wrist_drive(side, name)), *hand_bones(side, w, head, name)]
    return Rig(name="sgt", title="sgt's own skeleton with hands", bones=tuple(bones))


RIG = _build()

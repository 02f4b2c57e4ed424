"""The SMPL-X body: its 22 body joints (pelvis + the 21 of ``body_pose``) in SMPL-X order, then
the 15 joints of each hand (``left_index1`` .. ``right_thumb3``; see :data:`HAND_JOINT_NAMES`).
Hands rest flat (palm down, fingers along the arm), the pose SMPL-X's zero hand pose gives with
``flat_hand_mean=True``; the finger joints' rest positions are sgt's hand proportions.

Rest pose: SMPL-X's rest pose is its template with zero rotations (a T-pose, y up, facing +z,
left on +x). The joint positions below are the SMPL *neutral* template's joints (rounded to
0.1 mm; SMPL-X shares SMPL's body tree and joint names for these 22 joints). We cannot ship or
download the SMPL-X model (licence), so they stand in for SMPL-X's own neutral template joints,
which differ by a few centimetres in places: only the rest *directions* between joints matter
here (the rotations are computed against them), and docs/formats.md states the tolerance.
Source of the numbers: the SMPL neutral model's joint regressor applied to its template, as
quoted (approximately, 4 decimals) in public SMPL tooling.
"""

from __future__ import annotations

import numpy as np

from core.skeleton import BONE_LENGTHS
from renders.rigs.hands import hand_bones, t_pose_hand, wrist_drive
from renders.rigs.humanoid import HEAD, SPINE
from renders.rigs.rig import Aim, Bone, Rig

#: SMPL-X body joints 0..21 (joint 0, the pelvis, takes ``global_orient``; 1..21 are ``body_pose``).
JOINT_NAMES = (
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle", "right_ankle",
    "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
)
PARENTS = (-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19)
REST_JOINTS = np.array([
    [-0.0018, -0.2233, 0.0282], [0.0695, -0.3141, 0.0239], [-0.0678, -0.3143, 0.0219],
    [-0.0043, -0.1144, 0.0015], [0.1022, -0.6890, 0.0169], [-0.1060, -0.6964, 0.0151],
    [0.0012, 0.0209, 0.0026], [0.0885, -1.0874, -0.0266], [-0.0892, -1.0891, -0.0232],
    [0.0019, 0.0735, 0.0283], [0.1195, -1.1439, 0.0924], [-0.1194, -1.1440, 0.0969],
    [-0.0015, 0.2872, -0.0137], [0.0766, 0.1966, -0.0045], [-0.0746, 0.1950, -0.0093],
    [0.0012, 0.3533, 0.0376], [0.1985, 0.2402, -0.0161], [-0.1917, 0.2410, -0.0179],
    [0.4541, 0.2244, -0.0409], [-0.4540, 0.2217, -0.0443], [0.7196, 0.2350, -0.0470],
    [-0.7174, 0.2355, -0.0471],
])
TAILS = {  # leaves: top of the head, toes (approximate)
    "head": (0.0012, 0.5200, 0.0300), "left_foot": (0.1195, -1.1439, 0.1600), "right_foot": (-0.1194, -1.1440, 0.1600),
}
#: SMPL-X hand joints, in SMPL-X order per hand (joints 25..39 left, 40..54 right, after the jaw
#: and the eyes): ``left_hand_pose`` / ``right_hand_pose`` hold their rotations in this order.
HAND_JOINT_NAMES = tuple(f"{d}{k}" for d in ("index", "middle", "pinky", "ring", "thumb") for k in (1, 2, 3))
#: sgt's hand joint (the head of a finger bone) -> SMPL-X's hand joint name (after the side).
SGT_HAND = {f"{d}_{j}": f"{s}{k}" for d, s in (("index", "index"), ("middle", "middle"), ("ring", "ring"),
                                              ("little", "pinky")) for k, j in ((1, "mcp"), (2, "pip"), (3, "dip"))}
SGT_HAND.update({"thumb_cmc": "thumb1", "thumb_mcp": "thumb2", "thumb_ip": "thumb3"})
DRIVES = {
    "spine1": SPINE,
    "head": HEAD,
    "left_collar": Aim(("neck", "left_shoulder"), "left_shoulder"),
    "right_collar": Aim(("neck", "right_shoulder"), "right_shoulder"),
    "left_shoulder": Aim(("left_shoulder", "left_elbow"), "left_elbow"),
    "right_shoulder": Aim(("right_shoulder", "right_elbow"), "right_elbow"),
    "left_elbow": Aim(("left_elbow", "left_wrist"), "left_wrist"),
    "right_elbow": Aim(("right_elbow", "right_wrist"), "right_wrist"),
    "left_wrist": wrist_drive("left", lambda j: "left_" + SGT_HAND[j]),
    "right_wrist": wrist_drive("right", lambda j: "right_" + SGT_HAND[j]),
}


def _build() -> Rig:
    bones = []
    # Parents first: SMPL-X order already is (every parent index is smaller than its child's).
    for i, name in enumerate(JOINT_NAMES):
        parent = None if PARENTS[i] < 0 else JOINT_NAMES[PARENTS[i]]
        bones.append(Bone(name, parent, tuple(REST_JOINTS[i]), DRIVES.get(name), TAILS.get(name)))
    for side in ("left", "right"):  # a flat T-pose hand at the wrist (SMPL-X with flat_hand_mean=True)
        wrist = REST_JOINTS[JOINT_NAMES.index(f"{side}_wrist")]
        bones += hand_bones(side, f"{side}_wrist", t_pose_hand(side, wrist), lambda j, side=side: f"{side}_{SGT_HAND[j]}")
    torso = np.linalg.norm(REST_JOINTS[12] - REST_JOINTS[0]) / BONE_LENGTHS["neck"]
    return Rig(name="smplx", title="SMPL-X body and hand joints (SMPL-X names)", bones=tuple(bones),
               translation_scale=float(torso))


RIG = _build()

"""The rigs sgt exports to: each a table of bones, rest pose and drives (:mod:`renders.rigs.rig`).

``sgt export --rig NAME``: skeletal rigs (glTF, BVH; SMPL-X also as .npz) and robots (NAOqi
joint angles, :mod:`renders.naoqi`).
"""

from __future__ import annotations

from renders.rigs.humanoid import MIXAMO, VRM
from renders.rigs.rig import Aim, Bone, Orient, Rig
from renders.rigs.sgt import RIG as SGT
from renders.rigs.smplx import RIG as SMPLX

SKELETAL_RIGS: dict[str, Rig] = {"sgt": SGT, "vrm": VRM, "mixamo": MIXAMO, "smplx": SMPLX}
ROBOT_RIGS = ("nao", "pepper")
RIG_NAMES = tuple(SKELETAL_RIGS) + ROBOT_RIGS

__all__ = ["RIG_NAMES", "ROBOT_RIGS", "SKELETAL_RIGS", "Aim", "Bone", "Orient", "Rig", "get_rig"]


def get_rig(name: str) -> Rig:
    try:
        return SKELETAL_RIGS[name]
    except KeyError:
        raise KeyError(f"unknown rig '{name}' (skeletal rigs: {', '.join(SKELETAL_RIGS)})") from None

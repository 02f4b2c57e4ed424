"""One entry point for ``sgt export --rig``: a clip, a rig name and an output type -> a file."""

from __future__ import annotations

from core.motion import MotionClip
from renders.export import write_bvh
from renders.gltf import write_glb
from renders.naoqi import ROBOTS, write_angles
from renders.rigs import get_rig
from renders.smplx_npz import write_smplx_npz


def write_rig_file(path, clip: MotionClip, rig: str, suffix: str) -> str:
    """Write ``clip`` for ``rig`` as ``suffix`` (.glb/.vrma/.bvh/.npz/.json/.csv); returns a
    short note for the user ("" when there is nothing to say)."""
    if rig in ROBOTS:
        sol = write_angles(path, clip, ROBOTS[rig], "json" if suffix == ".json" else "csv")
        n = sol.n_frames * len(sol.names)  # Pepper has a joint more than NAO (HipPitch)
        pos = sum(int(v.sum()) for v in sol.position_clamped.values())
        vel = sum(int(v.sum()) for v in sol.velocity_clamped.values())
        return (f"{sol.robot.title}: {100 * pos / n:.1f}% of the angles clamped to the joint ranges, "
                f"{100 * vel / n:.1f}% to the joint speeds")
    target = get_rig(rig)
    if suffix in (".glb", ".vrma"):
        write_glb(path, clip, target, vrma=suffix == ".vrma")  # a .glb is a glTF, a .vrma a VRM Animation
        if clip.face is not None and rig != "sgt" and suffix == ".glb":
            return (f"no face: a glTF of the {rig} rig has none (the face: -o x.vrma for VRM expression tracks, "
                    "--rig sgt for morph targets, or --face)")
    elif suffix == ".bvh":
        write_bvh(path, clip, target)
    elif suffix == ".npz" and rig == "smplx":
        write_smplx_npz(path, clip)
    else:
        raise ValueError(f"rig {rig} cannot be written as {suffix}")
    return ""

"""Independent readers and checks for the rig exports (used by tests/test_rigs.py and
scripts/rig_errors.py). Nothing here imports sgt's retargeting: the expected values come from
sgt's joint positions and the conventions written in docs/formats.md.

Readers give, per bone name, the bone head's world position per frame (T, 3) and, where the
format has them, the bone's world rotation relative to its rest (T, 3, 3), y up.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

HERE = Path(__file__).resolve().parent


def _trs(node) -> np.ndarray:
    m = np.eye(4)
    if node.matrix:
        return np.array(node.matrix, dtype=np.float64).reshape(4, 4).T
    if node.rotation:
        m[:3, :3] = Rotation.from_quat(node.rotation).as_matrix()
    if node.scale:
        m[:3, :3] = m[:3, :3] @ np.diag(node.scale)
    if node.translation:
        m[:3, 3] = node.translation
    return m


def read_glb_pygltflib(path) -> dict:
    """pygltflib parses the file; forward kinematics here from nodes, skin and samplers."""
    import pygltflib

    g = pygltflib.GLTF2().load_binary(str(path))  # .vrma too (pygltflib picks by suffix otherwise)
    blob = g.binary_blob()

    def accessor(i: int) -> np.ndarray:
        a = g.accessors[i]
        v = g.bufferViews[a.bufferView]
        dtype = {5126: np.float32, 5123: np.uint16, 5125: np.uint32}[a.componentType]
        n = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[a.type]
        start = (v.byteOffset or 0) + (a.byteOffset or 0)
        return np.frombuffer(blob, dtype=dtype, count=a.count * n, offset=start).reshape(a.count, n)

    joints = g.skins[0].joints
    parent = {c: i for i, n in enumerate(g.nodes) for c in (n.children or [])}
    anim = g.animations[0]
    times = accessor(anim.samplers[0].input)[:, 0]
    T = len(times)
    local = {j: np.repeat(_trs(g.nodes[j])[None], T, axis=0) for j in joints}
    rest_local = {j: _trs(g.nodes[j]) for j in joints}
    for ch in anim.channels:
        out = accessor(anim.samplers[ch.sampler].output).astype(np.float64)
        j = ch.target.node
        if ch.target.path == "rotation":
            scale = np.linalg.norm(local[j][:, :3, :3], axis=1)  # keep any scale column
            local[j][:, :3, :3] = Rotation.from_quat(out).as_matrix() * scale[:, None, :]
        elif ch.target.path == "translation":
            local[j][:, :3, 3] = out

    def world_of(mats: dict) -> dict:
        out = {}

        def get(j):
            if j not in out:
                p = parent.get(j)
                out[j] = mats[j] if p is None or p not in mats else get(p) @ mats[j]
            return out[j]

        for j in joints:
            get(j)
        return out

    world, rest = world_of(local), world_of(rest_local)
    names = {j: g.nodes[j].name for j in joints}
    return {
        "times": times,
        "heads": {names[j]: world[j][:, :3, 3] for j in joints},
        "rotations": {names[j]: world[j][:, :3, :3] @ rest[j][:3, :3].T for j in joints},
        "world": {names[j]: world[j] for j in joints},
        "rest_world": {names[j]: rest[j] for j in joints},
        "rest_heads": {names[j]: rest[j][:3, 3] for j in joints},
        "extensions": g.extensions or {},
        "node_names": [n.name for n in g.nodes],
    }


def read_bvh_bvhio(path) -> dict:
    import bvhio

    root = bvhio.readAsHierarchy(str(path))
    bvh = bvhio.readAsBvh(str(path))
    heads: dict[str, list] = {j.Name: [] for j, _, _ in root.layout()}
    for f in range(bvh.FrameCount):
        root.loadPose(f)
        for j, _, _ in root.layout():
            heads[j.Name].append(np.array(j.PositionWorld, dtype=np.float64))
    return {"frame_time": bvh.FrameTime, "heads": {k: np.array(v) for k, v in heads.items()}}


BLENDER = shutil.which("blender")


def read_with_blender(paths: list, out_json) -> dict:
    """Blender's own glTF and BVH importers (tests/blender_dump.py), back in y-up."""
    cmd = [BLENDER, "-b", "--factory-startup", "--python", str(HERE / "blender_dump.py"), "--",
           str(out_json), *map(str, paths)]
    # Blender finds its Python on PATH: a pyenv/venv python there hides Debian's numpy from it.
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "PYENV", "VIRTUAL_ENV"))}
    env["PATH"] = "/usr/local/bin:/usr/bin:/bin"
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env, check=False)
    if proc.returncode != 0 or not Path(out_json).exists():
        raise RuntimeError(f"blender failed ({proc.returncode}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    data = json.loads(Path(out_json).read_text())
    c = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])  # Blender world = c @ glTF world
    out = {}
    for path in paths:
        d = data[str(path)]
        out[str(path)] = {
            "fps": d["fps"],
            "heads": {k: np.array(v) @ c for k, v in d["heads"].items()},  # rows: c.T @ x
            "rotations": {k: c.T @ np.array(v) @ c for k, v in d["rotations"].items()},
        }
    return out


# -- expectations from sgt's joint positions (docs/formats.md) -------------------------------

def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _frame(primary, secondary):
    y = _unit(primary)
    x = _unit(secondary - np.sum(secondary * y, -1, keepdims=True) * y)
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def sgt_joints(clip) -> dict:
    """sgt's joints by name, the hands' too (``left_index_mcp``: core.hands, the data, not the
    retargeting)."""
    from core.hands import HAND_JOINTS, SIDES, hand_positions
    from core.skeleton import JOINTS

    pos = np.asarray(clip.positions, dtype=np.float64)
    out = {n: pos[:, i] for i, n in enumerate(JOINTS)}
    hands = hand_positions(pos, clip.hands)
    for s, side in enumerate(SIDES):
        out.update({f"{side}_{n}": hands[:, s, k] for k, n in enumerate(HAND_JOINTS)})
    return out


def _roll(points: dict, names) -> np.ndarray:
    first = points[names[1]] - points[names[0]]
    return first if len(names) == 2 else np.cross(first, points[names[3]] - points[names[2]])


def sgt_rest_joints() -> dict:
    from core.skeleton import BONE_LENGTHS, BONES, REST_DIRECTIONS, ROOT_POSITION

    out = {"spine": np.asarray(ROOT_POSITION, dtype=np.float64)}
    for p, c in BONES:
        out[c] = out[p] + np.asarray(REST_DIRECTIONS[c]) * BONE_LENGTHS[c]
    return out


def check(rig, clip, reader: dict) -> dict:
    """Error figures of a reader's output against sgt's motion, per the documented conventions.

    - ``aim_deg``: angle between each aimed bone (its head to the head it aims at) and the sgt
      segment that drives it; ``chain_mm``: where that head is against where the bone's rest
      length along the sgt direction puts it;
    - ``orient_deg``: the turn of each oriented bone from its rest against the turn of sgt's frame
      (from rotations when the reader has them, else from the child head's direction);
    - ``root_mm``: root head against rest + scale * (sgt root movement);
    - ``follow_deg``: bones without a drive keep their rest rotation relative to their parent;
    - ``roll_deg`` (hands, fingers: AimRoll): the bone's turn from its rest against the turn
      that carries the rig's rest frame (aim, rest roll direction) onto sgt's (aim, roll); the
      same turn also places every child's head (the hand's knuckles), checked in ``chain_mm``.
    """
    from renders.rigs import Aim, Orient  # the mapping table is the spec; the math is redone here
    from renders.rigs.rig import AimRoll

    j, rest = sgt_joints(clip), sgt_rest_joints()
    heads = reader["heads"]
    rots = reader.get("rotations")
    rest_heads = {b.name: np.asarray(b.head) for b in rig.bones}
    out = {"aim_deg": 0.0, "chain_mm": 0.0, "orient_deg": 0.0, "root_mm": 0.0, "follow_deg": 0.0, "roll_deg": 0.0}
    for b in rig.bones:
        d = b.drive
        if isinstance(d, AimRoll):
            end = rest_heads[d.to] if d.to is not None else np.asarray(b.tail)
            want = _frame(j[d.source[1]] - j[d.source[0]], _roll(j, d.roll)) @ \
                _frame(end - rest_heads[b.name], _roll(rest_heads, d.rig_roll)).T
            if rots is not None:
                r = np.swapaxes(want, -1, -2) @ rots[b.name]
                err = np.degrees(np.arccos(np.clip((np.trace(r, axis1=-2, axis2=-1) - 1) / 2, -1, 1)))
                out["roll_deg"] = max(out["roll_deg"], float(err.max()))
            for kid in (k for k in rig.bones if k.parent == b.name):  # every child (the knuckles): the roll by positions
                at = heads[b.name] + want @ (rest_heads[kid.name] - rest_heads[b.name])
                mm = np.linalg.norm(heads[kid.name] - at, axis=-1) * 1000
                out["chain_mm"] = max(out["chain_mm"], float(mm.max()))
        if isinstance(d, (Aim, AimRoll)) and d.to is not None:
            want = _unit(j[d.source[1]] - j[d.source[0]])
            got = heads[d.to] - heads[b.name]
            err = np.degrees(np.arccos(np.clip(np.sum(_unit(got) * want, -1), -1, 1)))
            out["aim_deg"] = max(out["aim_deg"], float(err.max()))
            length = np.linalg.norm(rest_heads[d.to] - rest_heads[b.name])
            mm = np.linalg.norm(heads[b.name] + length * want - heads[d.to], axis=-1) * 1000
            out["chain_mm"] = max(out["chain_mm"], float(mm.max()))
        elif isinstance(d, Orient):
            f = _frame(j[d.primary[1]] - j[d.primary[0]], j[d.secondary[1]] - j[d.secondary[0]])
            f0 = _frame(rest[d.primary[1]] - rest[d.primary[0]], rest[d.secondary[1]] - rest[d.secondary[0]])
            want = f @ f0.T
            if rots is not None:
                r = np.swapaxes(want, -1, -2) @ rots[b.name]
                err = np.degrees(np.arccos(np.clip((np.trace(r, axis1=-2, axis2=-1) - 1) / 2, -1, 1)))
            else:
                kid = next((k.name for k in rig.bones if k.parent == b.name), None)
                if kid is None:
                    continue
                v = want @ (rest_heads[kid] - rest_heads[b.name])
                got = heads[kid] - heads[b.name]
                err = np.degrees(np.arccos(np.clip(np.sum(_unit(got) * _unit(v), -1), -1, 1)))
            out["orient_deg"] = max(out["orient_deg"], float(err.max()))
        elif d is None and b.parent is not None and rots is not None:
            r = np.swapaxes(rots[b.parent], -1, -2) @ rots[b.name]
            err = np.degrees(np.arccos(np.clip((np.trace(r, axis1=-2, axis2=-1) - 1) / 2, -1, 1)))
            out["follow_deg"] = max(out["follow_deg"], float(err.max()))
    root = rig.bones[0]
    want_root = np.asarray(root.head) + rig.translation_scale * (j[rig.root_source] - rest[rig.root_source])
    out["root_mm"] = float(np.linalg.norm(heads[root.name] - want_root, axis=-1).max() * 1000)
    return out


def sgt_position_error_mm(clip, reader: dict) -> float:
    """sgt's own rig: every joint's head (the hands' joints too, but the fingertips, which end
    bones) against sgt's joint position."""
    j = sgt_joints(clip)
    return float(max(np.linalg.norm(reader["heads"][n] - j[n], axis=-1).max() for n in j if n in reader["heads"]) * 1000)


# -- robots -----------------------------------------------------------------------------------

# URDF-style chains (origin xyz, origin rpy, axis) from Aldebaran's generated URDFs and link pages,
# written out again here so the check does not reuse the solver's own formulas.
CHAINS = {
    "nao": {"upper": (0.105, 0.015, 0.0), "elbow_rpy": (0.0, 0.0, 0.0), "fore": 0.05595},
    "pepper": {"upper": (0.1812, 0.015, 0.00013), "elbow_rpy": (0.0, -0.157079, 0.0), "fore": 0.15},
}


def _urdf_fk(angles: dict, robot: str, side: str) -> tuple[np.ndarray, np.ndarray]:
    c = CHAINS[robot]
    p = "L" if side == "left" else "R"
    sign = 1.0 if side == "left" else -1.0
    rot = (Rotation.from_rotvec(np.outer(angles[p + "ShoulderPitch"], [0, 1, 0]))
           * Rotation.from_rotvec(np.outer(angles[p + "ShoulderRoll"], [0, 0, 1])))
    ux, uy, uz = c["upper"]
    upper = rot.apply([ux, sign * uy, uz])
    elbow = (rot * Rotation.from_euler("xyz", c["elbow_rpy"])
             * Rotation.from_rotvec(np.outer(angles[p + "ElbowYaw"], [1, 0, 0]))
             * Rotation.from_rotvec(np.outer(angles[p + "ElbowRoll"], [0, 0, 1])))
    return upper, elbow.apply([c["fore"], 0.0, 0.0])


def _sgt_torso_directions(clip) -> dict:
    """sgt's bones in its torso's frame, NAOqi axes (x forward, y left, z up)."""
    j, rest = sgt_joints(clip), sgt_rest_joints()
    turn = _frame(j["neck"] - j["spine"], j["left_shoulder"] - j["right_shoulder"]) @ \
        _frame(rest["neck"] - rest["spine"], rest["left_shoulder"] - rest["right_shoulder"]).T
    out = {}
    for side in ("left", "right"):
        for name, (a, b) in (("upper", ("shoulder", "elbow")), ("fore", ("elbow", "wrist"))):
            v = np.einsum("tji,tj->ti", turn, j[f"{side}_{b}"] - j[f"{side}_{a}"])
            out[f"{side}_{name}"] = v[:, [2, 0, 1]]
    return out


def _angle_deg(a, b):
    cos = np.sum(a * b, -1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1)
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def robot_figures(clip, robot_name: str) -> dict:
    """Angular errors (degrees) of the robot's arm bones against sgt's, before and after the limits."""
    from renders.naoqi import ROBOTS, solve

    sol = solve(clip, ROBOTS[robot_name])
    want = _sgt_torso_directions(clip)
    out = {}
    for key, angles in (("raw", sol.raw), ("limited", sol.angles)):
        errs = []
        for side in ("left", "right"):
            upper, fore = _urdf_fk(angles, robot_name, side)
            errs += [_angle_deg(upper, want[f"{side}_upper"]), _angle_deg(fore, want[f"{side}_fore"])]
        e = np.concatenate(errs)
        out[key] = {"median": float(np.median(e)), "p95": float(np.percentile(e, 95)), "max": float(e.max())}
    n = sol.n_frames * len(sol.angles)
    out["position_clamped"] = sum(int(v.sum()) for v in sol.position_clamped.values()) / n
    out["velocity_clamped"] = sum(int(v.sum()) for v in sol.velocity_clamped.values()) / n
    return out


if __name__ == "__main__":  # pragma: no cover
    sys.exit("import this module")

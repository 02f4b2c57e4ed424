"""glTF 2.0 binary (.glb) export: a rig's skeleton, a skinned mannequin and the take's animation.

Layout (one scene):

- one node per rig bone, named as the rig names it, parents first; a node's ``translation``
  is its rest offset from its parent (in the parent's rest frame), its ``rotation`` its rest
  rotation relative to the parent (identity for the T-pose rigs);
- a skin over those nodes (``inverseBindMatrices`` = inverse rest world matrices) and a node
  ``mannequin`` with a mesh of one box per bone, each vertex bound to its bone alone;
- one animation, ``take``: a LINEAR ``rotation`` channel per bone and a ``translation``
  channel for the root, keys at ``i / 15`` s (15 fps), quaternions sign-continuous;
- with the VRM rig and ``vrma`` (a ``.vrma``), the ``VRMC_vrm_animation`` extension (spec 1.0)
  maps VRM humanoid bone names to nodes, so the file is a VRM Animation; a take with a face adds
  the extension's ``expressions``: a node per VRM preset expression
  (:data:`renders.face_export.VRM_EXPRESSIONS`) whose ``translation.x`` carries its weight.
  Without ``vrma`` (a ``.glb``) it is a plain glTF of the VRM skeleton, with no face;
- with sgt's own rig and a face, a node ``face``: the head and face of :mod:`renders.face_rig`
  (a mesh per colour) with a morph target per ARKit blendshape (their names in the mesh's
  ``extras.targetNames``, as Blender and three.js read them), animated by a ``weights`` channel
  and by ``translation`` and ``rotation`` channels that carry it with the head.

Units: metres, y up, the character facing +z (glTF's own conventions).
"""

from __future__ import annotations

import json
import struct

import numpy as np

from core.face import ARKIT_NAMES
from core.fileio import atomic_write
from core.motion import MotionClip
from core.skeleton import FPS
from renders import face_rig
from renders.face_export import vrm_expressions
from renders.rigs import Rig
from renders.rigs.retarget import RigMotion, retarget_clip
from renders.rotations import continuous_quats, matrix_to_quat

FLOAT, UINT16, UINT32 = 5126, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
VRMA_EXTENSION = "VRMC_vrm_animation"


class _Buffer:
    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(self, array: np.ndarray, component: int, kind: str, target: int | None = None,
            minmax: bool = False) -> int:
        dtype = {FLOAT: "<f4", UINT16: "<u2", UINT32: "<u4"}[component]
        a = np.ascontiguousarray(array, dtype=dtype)
        while len(self.data) % 4:
            self.data.append(0)
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": a.nbytes}
        if target is not None:
            view["byteLength"] = a.nbytes
            view["target"] = target
        self.data += a.tobytes()
        self.views.append(view)
        count = a.shape[0]
        acc = {"bufferView": len(self.views) - 1, "componentType": component, "count": int(count), "type": kind}
        if minmax:
            flat = a.reshape(count, -1)
            acc["min"] = [float(x) for x in flat.min(axis=0)]
            acc["max"] = [float(x) for x in flat.max(axis=0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _segment_end(rig: Rig, i: int) -> np.ndarray | None:
    bone = rig.bones[i]
    if bone.tail is not None:
        return np.asarray(bone.tail, dtype=np.float64)
    if bone.drive is not None and getattr(bone.drive, "to", None):
        return rig.aim_end(bone)
    kids = rig.children(bone.name)
    return np.asarray(rig.bones[rig.index[kids[0]]].head, dtype=np.float64) if kids else None


def mannequin_mesh(rig: Rig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A box around every bone segment: positions (V, 3), joint index per vertex (V,), triangles (F, 3)."""
    corners = np.array([[a, b] for a in (-1, 1) for b in (-1, 1)], dtype=np.float64)
    quad_faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    pos, joints, tris = [], [], []
    heads = rig.heads()
    for i in range(len(rig.bones)):
        end = _segment_end(rig, i)
        if end is None:
            continue
        d = end - heads[i]
        length = float(np.linalg.norm(d))
        if length < 1e-4:
            continue
        d /= length
        u = np.cross(d, [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
        u /= np.linalg.norm(u)
        v = np.cross(d, u)
        r = float(np.clip(0.12 * length, 0.012, 0.05))
        base = len(pos)
        for t in (0.0, length):
            for a, b in corners:
                pos.append(heads[i] + d * t + r * (a * u + b * v))
                joints.append(i)
        for q in quad_faces:
            tris.append((base + q[0], base + q[1], base + q[2]))
            tris.append((base + q[0], base + q[2], base + q[3]))
    return np.array(pos), np.array(joints), np.array(tris)


def glb_bytes(clip: MotionClip, rig: Rig, mesh: bool = True, vrma: bool = True) -> bytes:
    """The .glb file for ``clip`` on ``rig``. With the VRM rig, ``vrma`` makes it a VRM
    Animation (the ``VRMC_vrm_animation`` extension, and the face's expression tracks);
    without, a plain glTF of the VRM skeleton (``sgt export --rig vrm -o x.glb``)."""
    motion: RigMotion = retarget_clip(rig, clip)
    buf = _Buffer()
    parents = rig.parent_indices()
    r0 = rig.rest_rotations()
    heads = rig.heads()
    nodes: list[dict] = []
    for i, bone in enumerate(rig.bones):
        p = parents[i]
        if p < 0:
            t, rot = heads[i], r0[i]
        else:
            t, rot = r0[p].T @ (heads[i] - heads[p]), r0[p].T @ r0[i]
        node = {"name": bone.name, "translation": [float(x) for x in t],
                "rotation": [float(x) for x in matrix_to_quat(rot)]}
        kids = [rig.index[k] for k in rig.children(bone.name)]
        if kids:
            node["children"] = kids
        nodes.append(node)

    doc: dict = {"asset": {"version": "2.0", "generator": "sgt export"}, "scene": 0}
    scene_nodes = [0]
    if mesh:
        inverse_bind = np.zeros((len(rig.bones), 4, 4))
        inverse_bind[:, :3, :3] = np.swapaxes(r0, -1, -2)
        inverse_bind[:, :3, 3] = -np.einsum("bij,bj->bi", np.swapaxes(r0, -1, -2), heads)
        inverse_bind[:, 3, 3] = 1.0
        # glTF matrices are column-major
        ibm = buf.add(np.swapaxes(inverse_bind, -1, -2).reshape(-1, 16), FLOAT, "MAT4")
        v, j, f = mannequin_mesh(rig)
        weights = np.zeros((len(v), 4))
        weights[:, 0] = 1.0
        joints4 = np.zeros((len(v), 4))
        joints4[:, 0] = j
        attrs = {
            "POSITION": buf.add(v, FLOAT, "VEC3", ARRAY_BUFFER, minmax=True),
            "JOINTS_0": buf.add(joints4, UINT16, "VEC4", ARRAY_BUFFER),
            "WEIGHTS_0": buf.add(weights, FLOAT, "VEC4", ARRAY_BUFFER),
        }
        indices = buf.add(f.reshape(-1), UINT32, "SCALAR", ELEMENT_ARRAY_BUFFER)
        doc["materials"] = [{"name": "mannequin", "pbrMetallicRoughness": {
            "baseColorFactor": [0.25, 0.36, 0.55, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.75}}]
        doc["meshes"] = [{"name": "mannequin", "primitives": [{"attributes": attrs, "indices": indices, "material": 0}]}]
        doc["skins"] = [{"name": rig.name, "joints": list(range(len(rig.bones))), "skeleton": 0,
                         "inverseBindMatrices": ibm}]
        nodes.append({"name": "mannequin", "mesh": 0, "skin": 0})
        scene_nodes.append(len(nodes) - 1)

    times = np.arange(motion.n_frames, dtype=np.float64) / FPS
    t_acc = buf.add(times, FLOAT, "SCALAR", minmax=True)
    quats = continuous_quats(matrix_to_quat(motion.local))  # (T, B, 4)
    samplers, channels = [], []

    def channel(node: int, path: str, values: np.ndarray, kind: str) -> None:
        """A LINEAR channel animating ``path`` of ``node`` with ``values``, one key per frame."""
        samplers.append({"input": t_acc, "output": buf.add(values, FLOAT, kind), "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})

    for i in range(len(rig.bones)):
        channel(i, "rotation", quats[:, i], "VEC4")
    channel(0, "translation", motion.root_translation, "VEC3")

    face = clip.face
    if face is not None and mesh and rig.name == "sgt":
        _add_face(doc, buf, nodes, scene_nodes, clip, channel)
    extension = None
    if rig.vrm_animation and vrma:
        bones = {b.humanoid: {"node": i} for i, b in enumerate(rig.bones) if b.humanoid}
        extension = {"specVersion": "1.0", "humanoid": {"humanBones": bones}}
        if face is not None:
            preset = {}
            for name, weights in vrm_expressions(face).items():
                nodes.append({"name": f"expression_{name}", "translation": [0.0, 0.0, 0.0]})
                scene_nodes.append(len(nodes) - 1)
                preset[name] = {"node": len(nodes) - 1}
                xyz = np.zeros((len(weights), 3))
                xyz[:, 0] = weights
                channel(len(nodes) - 1, "translation", xyz, "VEC3")
            extension["expressions"] = {"preset": preset}

    doc["scenes"] = [{"name": "sgt", "nodes": scene_nodes}]
    doc["nodes"] = nodes
    doc["animations"] = [{"name": "take", "samplers": samplers, "channels": channels}]
    if extension is not None:
        doc["extensionsUsed"] = [VRMA_EXTENSION]
        doc["extensions"] = {VRMA_EXTENSION: extension}
    while len(buf.data) % 4:
        buf.data.append(0)
    doc["buffers"] = [{"byteLength": len(buf.data)}]
    doc["bufferViews"] = buf.views
    doc["accessors"] = buf.accessors
    js = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(buf.data)
    return b"".join([
        struct.pack("<4sII", b"glTF", 2, total),
        struct.pack("<I4s", len(js), b"JSON"), js,
        struct.pack("<I4s", len(buf.data), b"BIN\x00"), bytes(buf.data),
    ])


def _add_face(doc: dict, buf: _Buffer, nodes: list, scene_nodes: list, clip: MotionClip, channel) -> None:
    """The node ``face`` (see the module's docstring): a mesh per colour of
    :func:`renders.face_rig.morph_mesh`, its morph targets, and its channels."""
    face = clip.face
    materials, primitives = doc.setdefault("materials", []), []
    for part in face_rig.morph_mesh():
        materials.append({"name": "face", "pbrMetallicRoughness": {
            "baseColorFactor": [*part["color"], 1.0], "metallicFactor": 0.0, "roughnessFactor": part["roughness"]}})
        zero = None
        targets = []
        for delta in part["targets"]:
            if not np.any(delta):
                if zero is None:  # one accessor of zeros shared by the targets that leave this mesh be
                    zero = buf.add(delta, FLOAT, "VEC3", ARRAY_BUFFER, minmax=True)
                targets.append({"POSITION": zero})
            else:
                targets.append({"POSITION": buf.add(delta, FLOAT, "VEC3", ARRAY_BUFFER, minmax=True)})
        primitives.append({
            "attributes": {"POSITION": buf.add(part["positions"], FLOAT, "VEC3", ARRAY_BUFFER, minmax=True),
                           "NORMAL": buf.add(part["normals"], FLOAT, "VEC3", ARRAY_BUFFER)},
            "indices": buf.add(part["indices"].reshape(-1), UINT32, "SCALAR", ELEMENT_ARRAY_BUFFER),
            "material": len(materials) - 1, "targets": targets})
    n = len(ARKIT_NAMES)
    meshes = doc.setdefault("meshes", [])
    meshes.append({"name": "face", "primitives": primitives, "weights": [0.0] * n,
                   "extras": {"targetNames": list(ARKIT_NAMES)}})
    rotation, centre = face_rig.head_frames(clip.positions)
    nodes.append({"name": "face", "mesh": len(meshes) - 1, "translation": [float(x) for x in centre[0]],
                  "rotation": [float(x) for x in matrix_to_quat(rotation[0])]})
    scene_nodes.append(len(nodes) - 1)
    node = len(nodes) - 1
    channel(node, "translation", centre, "VEC3")
    channel(node, "rotation", continuous_quats(matrix_to_quat(rotation)), "VEC4")
    channel(node, "weights", np.clip(face.weights, 0.0, 1.0).reshape(-1), "SCALAR")


def write_glb(path, clip: MotionClip, rig: Rig, mesh: bool = True, vrma: bool = True) -> None:
    atomic_write(path, glb_bytes(clip, rig, mesh, vrma))

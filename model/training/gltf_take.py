"""A glTF 2.0 animation read as a take (``.glb``, or ``.gltf`` with its buffers), so that the BVH
path maps it onto sgt's skeleton (:mod:`model.training.loaders`: joints by node name, rest pose,
proportions).

Read bounded: the file by :func:`core.reading.read_bytes` (the motion capture limit), the JSON
by :func:`core.reading.loads_json` (its depth), a ``.gltf``'s external buffers only inside its
folder (:func:`core.fileio.resolved_inside`), each accessor checked against its buffer view and
buffer before a value is read, and only the keys that the sampled frames need are read from
them. Anything else is a :class:`~model.training.loaders.LoaderError` naming the file (and the
node, sampler or accessor).

The take: frame ``k`` is the animation at ``first key + k / fps`` seconds (``fps``: the keys'
own rate, or given), up to its last key. Its ``rotation``, ``translation`` and ``scale`` channels
are evaluated as the glTF specification says (``LINEAR``: linear, spherical for rotations;
``STEP``; ``CUBICSPLINE``: Hermite with the keys' tangents) on the node hierarchy (a node's
``matrix`` or its TRS; uniform scales only). Only the nodes the joint mapping names, and their
ancestors, are evaluated: :meth:`GltfTake.span` gives those frames as a :class:`Bvh` whose joints
are those nodes, whose rest pose (all channels zero) is the nodes' own transforms, and whose
channels turn each joint from it (world axes: y up, metres, the glTF frame).
"""

from __future__ import annotations

import base64
import binascii
import math
import struct
from pathlib import Path
from urllib.parse import unquote

import numpy as np

from core.fileio import OutputError, resolved_inside
from core.reading import InputFileError, loads_json, read_bytes
from model.training.loaders import MAX_JOINT_FRAMES, Bvh, BvhJoint, LoaderError, listed, read_take, resolve_mapping

#: The frame rates a take is read at (frames a second).
FPS_RANGE = (1.0, 1000.0)
#: The longest animation read, seconds (as a BVH take).
MAX_SECONDS = 4 * 3600

_COMPONENTS = {5120: ("<i1", 127.0), 5121: ("<u1", 255.0), 5122: ("<i2", 32767.0), 5123: ("<u2", 65535.0),
               5125: ("<u4", None), 5126: ("<f4", None)}
_WIDTH = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}
_PATHS = {"translation": 3, "rotation": 4, "scale": 3}
_CHANNELS = ["xposition", "yposition", "zposition", "zrotation", "xrotation", "yrotation"]


class GltfTake:
    """A glTF file's animation as a take: ``fps``, ``n_frames``, ``names`` (of every node)."""

    def __init__(self, path, animation: str | None = None, fps: float | None = None) -> None:
        self.path = Path(path)
        self.name = str(path)
        self.doc, self._bin = _document(self.path)
        self._buffers: dict[int, bytes] = {}
        nodes = self._list("nodes")
        if not nodes:
            raise self.error("it has no nodes")
        self.names = [n.get("name") if isinstance(n, dict) and isinstance(n.get("name"), str) and n.get("name")
                      else f"node{i}" for i, n in enumerate(nodes)]
        self.parents = self._parents(nodes)
        self.animation = self._animation(animation)
        self.channels = self._channels()
        start = min(float(t[0]) for t, _, _ in self.channels.values())
        end = max(float(t[-1]) for t, _, _ in self.channels.values())
        if end - start > MAX_SECONDS:
            raise self.error(f"the animation '{self.animation_name}' is {(end - start) / 3600:.1f} hours long; "
                             f"at most {MAX_SECONDS / 3600:g} hours are read")
        self.start = start
        self.fps = self._key_rate() if fps is None else float(fps)
        self.n_frames = math.floor((end - start) * self.fps + 1e-3) + 1  # (key times are float32)

    def error(self, message: str) -> LoaderError:
        return LoaderError(f"{self.name}: {message}")

    # -- the document ----------------------------------------------------------------------

    def _list(self, key: str) -> list:
        value = self.doc.get(key, [])
        if not isinstance(value, list):
            raise self.error(f"'{key}' is not a list")
        return value

    def _item(self, key: str, index, what: str) -> dict:
        items = self._list(key)
        if not isinstance(index, int) or isinstance(index, bool) or not 0 <= index < len(items) \
                or not isinstance(items[index], dict):
            raise self.error(f"{what} names {key}[{index!r}], which the file does not have")
        return items[index]

    def _parents(self, nodes: list) -> list[int]:
        parents = [-1] * len(nodes)
        for i, node in enumerate(nodes):
            kids = node.get("children", []) if isinstance(node, dict) else None
            if not isinstance(kids, list):
                raise self.error(f"node '{self.names[i]}': 'children' is not a list")
            for k in kids:
                if not isinstance(k, int) or isinstance(k, bool) or not 0 <= k < len(nodes):
                    raise self.error(f"node '{self.names[i]}' has a child {k!r} that is not a node")
                if parents[k] >= 0 or k == i:
                    raise self.error(f"node '{self.names[k]}' has two parents, or is its own child: "
                                     "the nodes must form trees")
                parents[k] = i
        for i in range(len(nodes)):  # a cycle has no root to reach
            seen, j = 0, i
            while j >= 0:
                j, seen = parents[j], seen + 1
                if seen > len(nodes):
                    raise self.error(f"node '{self.names[i]}' is its own ancestor: the nodes must form trees")
        return parents

    def _animation(self, wanted: str | None) -> dict:
        animations = self._list("animations")
        if not animations:
            raise self.error("it has no animation")
        names = [a.get("name") if isinstance(a, dict) and isinstance(a.get("name"), str) else f"animation{i}"
                 for i, a in enumerate(animations)]
        if wanted is None:
            if len(animations) > 1:
                raise self.error(f"it has {len(animations)} animations ({listed(names)}); "
                                 "choose one with --animation NAME")
            index = 0
        elif wanted in names:
            index = names.index(wanted)
        else:
            raise self.error(f"no animation named '{wanted}' (its animations: {listed(names)})")
        self.animation_name = names[index]
        if not isinstance(animations[index], dict):
            raise self.error(f"animation '{names[index]}' is not an object")
        return animations[index]

    def _channels(self) -> dict[tuple[int, str], tuple[np.ndarray, np.ndarray, str]]:
        """(node, path) -> (key times, key values (as stored: a view), interpolation)."""
        where = f"animation '{self.animation_name}'"
        samplers = self.animation.get("samplers", [])
        channels = self.animation.get("channels", [])
        if not isinstance(samplers, list) or not isinstance(channels, list):
            raise self.error(f"{where}: 'samplers' and 'channels' must be lists")
        out = {}
        for c in channels:
            target = c.get("target") if isinstance(c, dict) else None
            if not isinstance(target, dict) or target.get("path") not in _PATHS or "node" not in target:
                continue  # morph weights, or a channel for something other than a node's transform
            node = target["node"]
            if not isinstance(node, int) or isinstance(node, bool) or not 0 <= node < len(self.names):
                raise self.error(f"{where}: a channel targets node {node!r}, which the file does not have")
            s = c.get("sampler")
            if not isinstance(s, int) or isinstance(s, bool) or not 0 <= s < len(samplers) or not isinstance(samplers[s], dict):
                raise self.error(f"{where}: a channel names sampler {s!r}, which the animation does not have")
            sampler = samplers[s]
            interp = sampler.get("interpolation", "LINEAR")
            if interp not in ("LINEAR", "STEP", "CUBICSPLINE"):
                raise self.error(f"{where}, sampler {s}: unknown interpolation {interp!r} (LINEAR, STEP or CUBICSPLINE)")
            times = self._accessor(sampler.get("input"), f"{where}, sampler {s}'s input")[:, 0]
            values = self._accessor(sampler.get("output"), f"{where}, sampler {s}'s output")
            path = target["path"]
            per_key = 3 if interp == "CUBICSPLINE" else 1
            if values.shape != (len(times) * per_key, _PATHS[path]):
                raise self.error(f"{where}, sampler {s}: {len(times)} keys need {len(times) * per_key} {path} values "
                                 f"of {_PATHS[path]} numbers; the output has {values.shape[0]} of {values.shape[1]}")
            if not np.all(np.isfinite(times)) or not np.all(times[1:] > times[:-1]):
                raise self.error(f"{where}, sampler {s}: the key times must be finite and increasing")
            out[(node, path)] = (times, values, interp)
        if not out:
            raise self.error(f"the animation '{self.animation_name}' moves no node")
        return out

    def _key_rate(self) -> float:
        """The keys' own rate: one over the typical step of the channel with the most keys (to a
        whole number of frames a second where it is within 1 % of one)."""
        times = max((t for t, _, _ in self.channels.values()), key=len)
        if len(times) < 2:
            raise self.error("its animation has a single key: give the frame rate with --fps-in")
        rate = 1.0 / float(np.median(np.diff(times.astype(np.float64))))
        if abs(rate - round(rate)) < 0.01 * rate:
            rate = float(round(rate))
        low, high = FPS_RANGE
        if not low <= rate <= high:
            raise self.error(f"its keys come {rate:.4g} times a second; give the frame rate to read it at "
                             f"with --fps-in ({low:g} to {high:g})")
        return rate

    # -- buffers and accessors --------------------------------------------------------------

    def _buffer(self, index) -> bytes:
        if index in self._buffers:
            return self._buffers[index]
        buf = self._item("buffers", index, "a buffer view")
        uri = buf.get("uri")
        if uri is None:
            if index != 0 or self._bin is None:
                raise self.error(f"buffers[{index}] has no uri and the file no binary chunk")
            data = self._bin
        elif not isinstance(uri, str):
            raise self.error(f"buffers[{index}]: the uri is not a string")
        elif uri.startswith("data:"):
            head, _, body = uri.partition(",")
            if not head.endswith(";base64"):
                raise self.error(f"buffers[{index}]: a data uri must be base64")
            try:
                data = base64.b64decode(body, validate=True)
            except (binascii.Error, ValueError):
                raise self.error(f"buffers[{index}]: the data uri is not valid base64") from None
        else:
            try:
                data = read_bytes(resolved_inside(self.path.parent, unquote(uri)), "motion capture")
            except OutputError as exc:  # a link or a path out of the folder
                raise self.error(f"buffers[{index}]: {exc}") from None
            except InputFileError as exc:
                raise self.error(f"buffers[{index}] ({uri}): {exc.reason}") from None
            except OSError as exc:
                raise self.error(f"buffers[{index}]: cannot read {uri}: {exc.strerror or exc}") from None
        length = buf.get("byteLength")
        if not isinstance(length, int) or isinstance(length, bool) or length > len(data):
            raise self.error(f"buffers[{index}] declares {length!r} bytes; it has {len(data)}")
        self._buffers[index] = data[:length] if length < len(data) else data
        return self._buffers[index]

    def _accessor(self, index, what: str) -> np.ndarray:
        """(count, width) values of accessor ``index``: a view of its buffer (normalised
        integers as floats, read when sampled)."""
        acc = self._item("accessors", index, what)
        where = f"accessors[{index}] ({what})"
        if "sparse" in acc:
            raise self.error(f"{where}: sparse accessors are not read")
        comp, kind, count = acc.get("componentType"), acc.get("type"), acc.get("count")
        if comp not in _COMPONENTS or kind not in _WIDTH:
            raise self.error(f"{where}: a {kind!r} of component type {comp!r} is not an animation's key data")
        if not isinstance(count, int) or isinstance(count, bool) or count < 1:
            raise self.error(f"{where}: its count must be a whole number of at least 1")
        dtype, scale = _COMPONENTS[comp]
        item = np.dtype(dtype).itemsize
        width = _WIDTH[kind]
        view = self._item("bufferViews", acc.get("bufferView"), where)
        data = self._buffer(view.get("buffer"))
        numbers = [view.get("byteOffset", 0), view.get("byteLength"), acc.get("byteOffset", 0),
                   view.get("byteStride", width * item)]
        if not all(isinstance(x, int) and not isinstance(x, bool) and x >= 0 for x in numbers):
            raise self.error(f"{where}: its offsets, length and stride must be whole numbers")
        v_off, v_len, a_off, stride = numbers
        if stride < width * item or stride % item or (a_off + v_off) % item:
            raise self.error(f"{where}: a stride of {stride} bytes or an offset does not fit {width} values of {item} bytes")
        need = a_off + stride * (count - 1) + width * item
        if v_off + v_len > len(data) or need > v_len:
            raise self.error(f"{where}: {count} values need {need} bytes of a view of {v_len} "
                             f"(at {v_off} of a buffer of {len(data)})")
        values = np.ndarray((count, width), dtype=dtype, buffer=data, offset=v_off + a_off, strides=(stride, item))
        if scale is not None and acc.get("normalized"):
            return _Normalised(values, scale)
        return values

    # -- evaluation -------------------------------------------------------------------------

    def _skeleton(self, order: list[int]) -> Bvh:
        """The nodes in ``order`` as joints (names and parents only), for the mapping."""
        at = {n: k for k, n in enumerate(order)}
        joints = [BvhJoint(self.names[n], at.get(self.parents[n], -1), np.zeros(3)) for n in order]
        return Bvh(joints, 1.0 / self.fps, np.zeros((0, 0)), self.name)

    def _order(self, nodes) -> list[int]:
        """``nodes`` and their ancestors, parents first."""
        depth: dict[int, int] = {}
        for n in nodes:
            chain = []
            while n >= 0 and n not in depth:
                chain.append(n)
                n = self.parents[n]
            d = depth.get(n, -1)
            for m in reversed(chain):
                d += 1
                depth[m] = d
        return sorted(depth, key=lambda n: (depth[n], n))

    def span(self, a: int, b: int, mapping: dict | None = None) -> Bvh:
        """Frames ``a`` to ``b`` (exclusive) of the nodes the mapping needs, as a :class:`Bvh`."""
        order = self._order(range(len(self.names)))
        idx = resolve_mapping(self._skeleton(order), mapping)
        nodes = self._order([order[i] for i in idx.values()])
        if (b - a) * len(nodes) > MAX_JOINT_FRAMES:
            raise self.error(f"{b - a} frames of {len(nodes)} nodes are more than {MAX_JOINT_FRAMES} to compute: "
                             "take a shorter span")
        times = self.start + np.arange(a, b) / self.fps
        rest = {n: self._rest(n) for n in nodes}
        world, world0 = {}, {}
        for n in nodes:
            t, r, s = self._sampled(n, times, rest[n])
            world0[n] = _compose(world0.get(self.parents[n]), rest[n][0][None], rest[n][1][None], np.array([rest[n][2]]))
            world[n] = _compose(world.get(self.parents[n]), t, r, s)
        at = {n: k for k, n in enumerate(nodes)}
        joints, columns = [], []
        for k, n in enumerate(nodes):
            pos, rot, _ = world[n]
            pos0, rot0, _ = world0[n]
            turn = rot @ np.swapaxes(rot0, -1, -2)  # the node's turn from its rest, in world axes
            p = self.parents[n] if self.parents[n] in at else -1
            if p < 0:
                offset, local_pos, local = pos0[0], pos, turn
            else:
                ppos, prot, _ = world[p]
                pturn = prot @ np.swapaxes(world0[p][1], -1, -2)
                offset = pos0[0] - world0[p][0][0]
                local_pos = np.einsum("fji,fj->fi", pturn, pos - ppos)
                local = np.swapaxes(pturn, -1, -2) @ turn
            joints.append(BvhJoint(self.names[n], -1 if p < 0 else at[p], offset, list(_CHANNELS), 6 * k))
            columns += [local_pos, _euler_zxy(local)]
        motion = np.concatenate(columns, axis=1)
        if not np.all(np.isfinite(motion)):
            raise self.error("its animation has values that are not finite numbers")
        return Bvh(joints, 1.0 / self.fps, motion, self.name)

    def _rest(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A node's own translation, rotation matrix and (uniform) scale."""
        node = self._list("nodes")[n]
        where = f"node '{self.names[n]}'"
        if "matrix" in node:
            m = _numbers(node["matrix"], 16, where + ": matrix", self.error)
            m = np.asarray(m).reshape(4, 4).T  # column-major
            scale = np.linalg.norm(m[:3, :3], axis=0)
            if np.any(scale < 1e-12) or np.linalg.det(m[:3, :3]) < 0:
                raise self.error(f"{where}: its matrix collapses or mirrors its children")
            return m[:3, 3], m[:3, :3] / scale, self._uniform(scale, where)
        t = np.asarray(_numbers(node.get("translation", [0, 0, 0]), 3, where + ": translation", self.error))
        q = np.asarray(_numbers(node.get("rotation", [0, 0, 0, 1]), 4, where + ": rotation", self.error))
        s = np.asarray(_numbers(node.get("scale", [1, 1, 1]), 3, where + ": scale", self.error))
        if np.linalg.norm(q) < 1e-9:
            raise self.error(f"{where}: its rotation is not a rotation (a zero quaternion)")
        return t, _quat_matrix(q[None])[0], self._uniform(s, where)

    def _uniform(self, s: np.ndarray, where: str) -> float:
        s = np.asarray(s, dtype=np.float64)
        if np.any(s <= 0) or s.max() > s.min() * (1 + 1e-3):
            raise self.error(f"{where}: a scale of {np.round(s, 4).tolist()}; only uniform positive scales are read")
        return float(s.mean())

    def _sampled(self, n: int, times: np.ndarray, rest) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(F, 3) translations, (F, 3, 3) rotations, (F,) scales of node ``n`` at ``times``."""
        F = len(times)
        t = np.repeat(rest[0][None], F, axis=0)
        r = np.repeat(rest[1][None], F, axis=0)
        s = np.full(F, rest[2])
        if (n, "translation") in self.channels:
            t = _sample(*self.channels[(n, "translation")], times, False)
        if (n, "rotation") in self.channels:
            q = _sample(*self.channels[(n, "rotation")], times, True)
            if np.any(np.linalg.norm(q, axis=-1) < 1e-9):
                raise self.error(f"node '{self.names[n]}': its rotation keys hold a zero quaternion")
            r = _quat_matrix(q)
        if (n, "scale") in self.channels:
            v = _sample(*self.channels[(n, "scale")], times, False)
            if np.any(v <= 0) or np.any(v.max(axis=1) > v.min(axis=1) * (1 + 1e-3)):
                raise self.error(f"node '{self.names[n]}': its scale keys are not uniform and positive; "
                                 "only uniform scales are read")
            s = v.mean(axis=1)
        return t, r, s


class _Normalised:
    """A view of normalised integers read as floats in -1..1 (or 0..1) when indexed."""

    def __init__(self, values: np.ndarray, scale: float) -> None:
        self.values, self.scale = values, scale
        self.shape = values.shape

    def __getitem__(self, key) -> np.ndarray:
        return np.maximum(self.values[key].astype(np.float64) / self.scale, -1.0)


def _document(path: Path) -> tuple[dict, bytes | None]:
    """The glTF JSON and the binary chunk of a .glb (None for a .gltf)."""
    data = read_take(path, "a glTF file")
    binary = None
    if data[:4] == b"glTF":
        if len(data) < 20:
            raise LoaderError(f"{path}: the GLB file ends inside its header")
        version, length = struct.unpack_from("<II", data, 4)
        if version != 2:
            raise LoaderError(f"{path}: GLB version {version}; sgt reads glTF 2.0")
        end = min(length, len(data))
        chunks, at = [], 12
        while at + 8 <= end:
            size, kind = struct.unpack_from("<II", data, at)
            if at + 8 + size > end:
                raise LoaderError(f"{path}: a chunk of {size} bytes runs past the end of the file")
            chunks.append((kind, data[at + 8:at + 8 + size]))
            at += 8 + size + (-size % 4)
        if not chunks or chunks[0][0] != 0x4E4F534A:
            raise LoaderError(f"{path}: the GLB file does not start with its JSON chunk")
        text = chunks[0][1]
        binary = next((body for kind, body in chunks[1:] if kind == 0x004E4942), None)
    else:
        text = data
    try:
        doc = loads_json(text)
    except (ValueError, UnicodeDecodeError) as exc:
        raise LoaderError(f"{path}: not a glTF file ({exc})") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("asset"), dict):
        raise LoaderError(f"{path}: not a glTF file (no 'asset')")
    version = doc["asset"].get("version")
    if not isinstance(version, str) or not version.startswith("2."):
        raise LoaderError(f"{path}: glTF version {version!r}; sgt reads glTF 2.0")
    return doc, binary


def _numbers(value, count: int, where: str, error) -> list[float]:
    if not isinstance(value, list) or len(value) != count or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in value):
        raise error(f"{where} must be {count} finite numbers")
    return [float(x) for x in value]


def _sample(times: np.ndarray, values, interp: str, at: np.ndarray, rotation: bool) -> np.ndarray:
    """A sampler's values at the times ``at`` (held before its first key and after its last)."""
    k = len(times)
    i = np.clip(np.searchsorted(times, at, side="right") - 1, 0, k - 1)
    j = np.minimum(i + 1, k - 1)
    t0, t1 = times[i].astype(np.float64), times[j].astype(np.float64)
    u = np.where(t1 > t0, np.clip((at - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0, 1.0), 0.0)[:, None]
    if interp == "CUBICSPLINE":
        v0, v1 = values[3 * i + 1].astype(np.float64), values[3 * j + 1].astype(np.float64)
        b0, a1 = values[3 * i + 2].astype(np.float64), values[3 * j].astype(np.float64)
        dt = (t1 - t0)[:, None]
        out = ((2 * u**3 - 3 * u**2 + 1) * v0 + dt * (u**3 - 2 * u**2 + u) * b0
               + (-2 * u**3 + 3 * u**2) * v1 + dt * (u**3 - u**2) * a1)
    else:
        v0, v1 = values[i].astype(np.float64), values[j].astype(np.float64)
        if interp == "STEP":
            out = v0
        elif rotation:
            out = _slerp(v0, v1, u[:, 0])
        else:
            out = v0 + (v1 - v0) * u
    if rotation:
        out = out / np.maximum(np.linalg.norm(out, axis=-1, keepdims=True), 1e-300)
    return out


def _slerp(q0: np.ndarray, q1: np.ndarray, u: np.ndarray) -> np.ndarray:
    q0 = q0 / np.maximum(np.linalg.norm(q0, axis=-1, keepdims=True), 1e-300)
    q1 = q1 / np.maximum(np.linalg.norm(q1, axis=-1, keepdims=True), 1e-300)
    dot = np.sum(q0 * q1, axis=-1)
    q1 = np.where((dot < 0)[:, None], -q1, q1)  # the short way round
    dot = np.clip(np.abs(dot), 0.0, 1.0)
    angle = np.arccos(dot)
    small = angle < 1e-6
    sin = np.where(small, 1.0, np.sin(angle))
    w0 = np.where(small, 1.0 - u, np.sin((1.0 - u) * angle) / sin)
    w1 = np.where(small, u, np.sin(u * angle) / sin)
    return w0[:, None] * q0 + w1[:, None] * q1


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    """(F, 4) quaternions (x, y, z, w) -> (F, 3, 3) rotation matrices."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def _compose(parent, t: np.ndarray, r: np.ndarray, s: np.ndarray):
    """World (position, rotation, scale) of a node from its parent's (None: a root) and its own."""
    if parent is None:
        return t, r, s
    ppos, prot, pscale = parent
    return ppos + pscale[:, None] * np.einsum("fij,fj->fi", prot, t), prot @ r, pscale * s


def _euler_zxy(m: np.ndarray) -> np.ndarray:
    """(F, 3, 3) rotations -> (F, 3) degrees (z, x, y) with R = Rz @ Rx @ Ry (BVH's
    ``Zrotation Xrotation Yrotation``)."""
    x = np.arctan2(m[:, 2, 1], np.hypot(m[:, 2, 0], m[:, 2, 2]))
    lock = np.hypot(m[:, 0, 1], m[:, 1, 1]) < 1e-9
    z = np.where(lock, np.arctan2(m[:, 1, 0], m[:, 0, 0]), np.arctan2(-m[:, 0, 1], m[:, 1, 1]))
    y = np.where(lock, 0.0, np.arctan2(-m[:, 2, 0], m[:, 2, 2]))
    return np.degrees(np.stack([z, x, y], axis=-1))

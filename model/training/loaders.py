"""Real speech-gesture data that users own, mapped onto sgt's 10-joint skeleton.

Supported: BVH motion + WAV audio + word timings (Praat TextGrid or JSON), as in the GENEA /
Trinity Speech-Gesture layout (``Motion/*.bvh``, ``Audio/*.wav``, ``Transcripts/*.json`` or
``*.TextGrid``) or BEAT-style flat folders (``NAME.bvh``, ``NAME.wav``, ``NAME.TextGrid``).
Timings files are read with :func:`dsl.speech.recording.read_timings` (TextGrid or
``[{"word", "start", "end"}]`` JSON).

BVH (:func:`read_bvh`): the hierarchy (offsets, channels, any Euler order, End Sites named
``PARENT_End``), forward kinematics to world positions, then (:func:`bvh_to_poses`):

- joint mapping (:data:`DEFAULT_MAPPING`, overridable per joint) onto spine, neck, head,
  upper-arm roots (shoulders), forearms (elbows) and hands (wrists); the nose is estimated as
  a point in front of the head (the face direction of the zero pose, carried by the head's
  rotation) and head_top from the head's end site, or above the head;
- units: centimetres are detected (or set with ``scale``) and converted to metres;
- axes: the up axis is found from the zero pose (or given), rotated to +y; a rotation about y
  puts the shoulder line on x with the chest facing +z (the character's left on +x);
- resampling to :data:`core.skeleton.FPS` (linear interpolation of joint positions);
- poses (T, 27) via :func:`core.skeleton.pose_from_positions`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.skeleton import FPS, JOINTS, pose_from_positions
from core.words import TimedWord
from dsl.speech.recording import read_timings
from dsl.speech.types import SpeechError
from model.features import audio_features, load_audio, word_features


class LoaderError(Exception):
    """A user-facing problem with a data file (message names the file)."""


# -- BVH ------------------------------------------------------------------------------------


@dataclass
class BvhJoint:
    name: str
    parent: int  # index, -1 for the root
    offset: np.ndarray
    channels: list[str] = field(default_factory=list)
    channel_start: int = 0
    end_site: bool = False


@dataclass
class Bvh:
    joints: list[BvhJoint]
    frame_time: float
    motion: np.ndarray  # (F, n_channels) float64

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def names(self) -> list[str]:
        return [j.name for j in self.joints]

    def index(self, name: str) -> int:
        return self.names.index(name)


_AXIS = {"x": 0, "y": 1, "z": 2}


_CHANNEL_NAMES = ("xposition", "yposition", "zposition", "xrotation", "yrotation", "zrotation")


class _Tokens:
    """BVH text as whitespace-separated tokens, read in order; problems name the file."""

    def __init__(self, text: str, name: str) -> None:
        self.toks = text.split()
        self.pos = 0
        self.name = name

    def error(self, message: str) -> LoaderError:
        return LoaderError(f"{self.name}: {message}")

    def next(self, what: str) -> str:
        if self.pos >= len(self.toks):
            raise self.error(f"the BVH file ends early (expected {what})")
        self.pos += 1
        return self.toks[self.pos - 1]

    def number(self, what: str) -> float:
        tok = self.next(what)
        try:
            return float(tok)
        except ValueError:
            raise self.error(f"expected a number for {what}, found {tok!r}") from None

    def count(self, what: str) -> int:
        value = self.number(what)
        if not math.isfinite(value) or value < 0:
            raise self.error(f"expected a count for {what}, found {value:g}")
        return int(value)

    def rest(self) -> list[str]:
        return self.toks[self.pos:]


def parse_bvh(text: str, name: str = "<bvh>") -> Bvh:
    """Parse BVH text (see module docstring)."""
    toks = _Tokens(text, name)
    if toks.next("HIERARCHY").upper() != "HIERARCHY":
        raise toks.error("not a BVH file (it must start with HIERARCHY)")
    joints, n_channels = _hierarchy(toks)
    frame_time, motion = _motion(toks, n_channels)
    return Bvh(joints, frame_time, motion)


def _hierarchy(toks: _Tokens) -> tuple[list[BvhJoint], int]:
    """The joints up to ``MOTION`` and the number of channels per frame."""
    joints: list[BvhJoint] = []
    stack: list[int] = []  # the open joints, innermost last
    n_channels = 0
    while True:
        tok = toks.next("ROOT, JOINT, End or MOTION")
        up = tok.upper()
        if up in ("ROOT", "JOINT"):
            _open_joint(toks, up, joints, stack)
        elif up == "END":
            _open_end_site(toks, joints, stack)
        elif up == "OFFSET":
            joint = _innermost(toks, joints, stack, "OFFSET")
            joint.offset = np.array([toks.number("OFFSET x"), toks.number("OFFSET y"), toks.number("OFFSET z")])
        elif up == "CHANNELS":
            n_channels += _read_channels(toks, _innermost(toks, joints, stack, "CHANNELS"), n_channels)
        elif tok == "}":
            if not stack:
                raise toks.error("unbalanced '}'")
            stack.pop()
        elif up == "MOTION":
            break
        else:
            raise toks.error(f"unexpected {tok!r} in the hierarchy")
    if stack:
        raise toks.error("the hierarchy has unclosed joints")
    if not joints:
        raise toks.error("the hierarchy has no joints")
    return joints, n_channels


def _open_joint(toks: _Tokens, kind: str, joints: list[BvhJoint], stack: list[int]) -> None:
    jname = toks.next("a joint name")
    if toks.next("{") != "{":
        raise toks.error(f"expected '{{' after joint {jname!r}")
    if kind == "ROOT" and stack:
        raise toks.error(f"ROOT {jname!r} inside another joint")
    joints.append(BvhJoint(jname, stack[-1] if stack else -1, np.zeros(3)))
    stack.append(len(joints) - 1)


def _open_end_site(toks: _Tokens, joints: list[BvhJoint], stack: list[int]) -> None:
    toks.next("Site")
    if toks.next("{") != "{":
        raise toks.error("expected '{' after End Site")
    if not stack:
        raise toks.error("End Site outside a joint")
    joints.append(BvhJoint(f"{joints[stack[-1]].name}_End", stack[-1], np.zeros(3), end_site=True))
    stack.append(len(joints) - 1)


def _innermost(toks: _Tokens, joints: list[BvhJoint], stack: list[int], keyword: str) -> BvhJoint:
    if not stack:
        raise toks.error(f"{keyword} outside a joint")
    return joints[stack[-1]]


def _read_channels(toks: _Tokens, joint: BvhJoint, first: int) -> int:
    """Read a CHANNELS line into ``joint`` (its channels start at column ``first``); returns their count."""
    count = toks.count("the channel count")
    chans = [toks.next("a channel name") for _ in range(count)]
    for c in chans:
        if c.lower() not in _CHANNEL_NAMES:
            raise toks.error(f"unknown channel {c!r} of joint {joint.name!r}")
    joint.channels, joint.channel_start = [c.lower() for c in chans], first
    return count


def _motion(toks: _Tokens, n_channels: int) -> tuple[float, np.ndarray]:
    """The MOTION section: frame time and the (frames, channels) values."""
    if toks.next("Frames:").rstrip(":").lower() != "frames":
        raise toks.error("expected 'Frames:' after MOTION")
    n_frames = toks.count("the frame count")
    if toks.next("Frame").lower() != "frame" or toks.next("Time:").rstrip(":").lower() != "time":
        raise toks.error("expected 'Frame Time:'")
    frame_time = toks.number("the frame time")
    if not frame_time > 0:
        raise toks.error(f"the frame time must be positive, got {frame_time}")
    values = toks.rest()
    need = n_frames * n_channels
    if len(values) < need:
        raise toks.error(f"{n_frames} frames of {n_channels} channels need {need} numbers, found {len(values)}")
    try:
        motion = np.array(values[:need], dtype=np.float64).reshape(n_frames, n_channels)
    except ValueError:
        raise toks.error("the motion data has a value that is not a number") from None
    return frame_time, motion


def read_bvh(path) -> Bvh:
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        raise LoaderError(f"cannot read {str(p)!r}: {e}") from None
    return parse_bvh(text, str(p))


def _axis_rot(axis: int, deg: np.ndarray) -> np.ndarray:
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    if axis == 0:
        rows = [[o, z, z], [z, c, -s], [z, s, c]]
    elif axis == 1:
        rows = [[c, z, s], [z, o, z], [-s, z, c]]
    else:
        rows = [[c, -s, z], [s, c, z], [z, z, o]]
    return np.stack([np.stack(r, -1) for r in rows], -2)


def forward_kinematics(bvh: Bvh) -> tuple[np.ndarray, np.ndarray]:
    """World positions (F, J, 3) and rotations (F, J, 3, 3) in the file's units and axes.

    Rotation channels compose in the order listed (``Zrotation Xrotation Yrotation`` means
    R = Rz @ Rx @ Ry); position channels replace the joint's offset.
    """
    F = len(bvh.motion)
    J = len(bvh.joints)
    pos = np.zeros((F, J, 3))
    rot = np.zeros((F, J, 3, 3))
    for i, j in enumerate(bvh.joints):
        local_t = np.broadcast_to(j.offset, (F, 3)).copy()
        local_r = np.broadcast_to(np.eye(3), (F, 3, 3)).copy()
        for k, ch in enumerate(j.channels):
            v = bvh.motion[:, j.channel_start + k]
            if ch.endswith("position"):
                local_t[:, _AXIS[ch[0]]] = v
            else:
                local_r = local_r @ _axis_rot(_AXIS[ch[0]], v)
        if j.parent < 0:
            pos[:, i], rot[:, i] = local_t, local_r
        else:
            pr = rot[:, j.parent]
            pos[:, i] = pos[:, j.parent] + np.einsum("fij,fj->fi", pr, local_t)
            rot[:, i] = pr @ local_r
    return pos, rot


def zero_pose_positions(bvh: Bvh) -> np.ndarray:
    """(J, 3) positions with all rotations zero (offsets only)."""
    out = np.zeros((len(bvh.joints), 3))
    for i, j in enumerate(bvh.joints):
        out[i] = j.offset + (out[j.parent] if j.parent >= 0 else 0.0)
    return out


# -- joint mapping --------------------------------------------------------------------------

#: sgt joint -> BVH joint names tried in order (case-insensitive, prefixes like "mixamorig:" ignored).
DEFAULT_MAPPING: dict[str, tuple[str, ...]] = {
    "spine": ("Spine", "Spine1", "spine_01", "Chest", "Hips", "pelvis"),
    "neck": ("Neck", "Neck1", "neck_01", "Neck2"),
    "head": ("Head", "head"),
    "head_top": ("HeadEnd", "Head_End", "HeadTop_End", "head_top", "Head_Nub", "Head_end"),
    "left_shoulder": ("LeftArm", "LeftUpArm", "LeftUpperArm", "L_UpperArm", "upperarm_l", "LeftShoulder1"),
    "left_elbow": ("LeftForeArm", "LeftLowArm", "LeftLowerArm", "L_Forearm", "lowerarm_l", "LeftElbow"),
    "left_wrist": ("LeftHand", "L_Hand", "hand_l", "LeftWrist"),
    "right_shoulder": ("RightArm", "RightUpArm", "RightUpperArm", "R_UpperArm", "upperarm_r", "RightShoulder1"),
    "right_elbow": ("RightForeArm", "RightLowArm", "RightLowerArm", "R_Forearm", "lowerarm_r", "RightElbow"),
    "right_wrist": ("RightHand", "R_Hand", "hand_r", "RightWrist"),
}
REQUIRED = ("spine", "neck", "head", "left_shoulder", "left_elbow", "left_wrist", "right_shoulder", "right_elbow", "right_wrist")


def _key(name: str) -> str:
    name = name.split(":")[-1]
    name = re.sub(r"^(bip0?1|mixamorig)[ _]?", "", name, flags=re.I)
    return re.sub(r"[^a-z0-9]", "", name.lower())


def resolve_mapping(bvh: Bvh, mapping: dict | None = None) -> dict[str, int]:
    """sgt joint (plus "head") -> BVH joint index; ``mapping`` entries (a name or list) come first."""
    by_key: dict[str, int] = {}
    for i, j in enumerate(bvh.joints):
        by_key.setdefault(_key(j.name), i)
    out = {}
    for joint, defaults in DEFAULT_MAPPING.items():
        cands: list[str] = []
        if mapping and joint in mapping:
            m = mapping[joint]
            cands += [m] if isinstance(m, str) else list(m)
        cands += list(defaults)
        for c in cands:
            if c in bvh.names:
                out[joint] = bvh.names.index(c)
                break
            if _key(c) in by_key:
                out[joint] = by_key[_key(c)]
                break
    missing = [j for j in REQUIRED if j not in out]
    if missing:
        raise LoaderError(f"cannot find BVH joints for {', '.join(missing)} (joints in the file: "
                          f"{', '.join(j.name for j in bvh.joints if not j.end_site)}); pass a mapping")
    return out


def _rot_y(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _up_rotation(up: str) -> np.ndarray:
    """Rotation taking the file's ``up`` axis ("x", "y", "z", "-z"...) to +y."""
    sign = -1.0 if up.startswith("-") else 1.0
    ax = up[-1].lower()
    if ax == "y":
        return np.diag([1.0, sign, sign])  # -y up: rotate 180 deg about x
    if ax == "z":
        # +z up: rotate -90 deg about x (y -> -z, z -> y)
        r = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
        return r if sign > 0 else np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    if ax == "x":
        r = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # x -> y
        return r if sign > 0 else np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    raise LoaderError(f"unknown up axis {up!r}: use x, y, z (or -x, -y, -z)")


def detect_up(bvh: Bvh, idx: dict[str, int]) -> str:
    z = zero_pose_positions(bvh)
    v = z[idx["head"]] - z[idx["spine"]]
    ax = int(np.argmax(np.abs(v)))
    return ("-" if v[ax] < 0 else "") + "xyz"[ax]


def detect_scale(bvh: Bvh, idx: dict[str, int]) -> float:
    """Metres per file unit: 0.01 when the spine-to-head distance looks like centimetres."""
    z = zero_pose_positions(bvh)
    d = float(np.linalg.norm(z[idx["head"]] - z[idx["spine"]]))
    return 0.01 if d > 5.0 else 1.0


def _resample(x: np.ndarray, src_fps: float, dst_fps: float = FPS) -> np.ndarray:
    """Linear interpolation of (F, ...) samples at src_fps onto dst_fps, from time 0."""
    F = len(x)
    if F == 0:
        return x
    duration = (F - 1) / src_fps
    n = int(math.floor(duration * dst_fps + 1e-3)) + 1
    t = np.arange(n) / dst_fps * src_fps
    i0 = np.clip(np.floor(t).astype(int), 0, F - 1)
    i1 = np.clip(i0 + 1, 0, F - 1)
    w = (t - i0).reshape(-1, *([1] * (x.ndim - 1)))
    return x[i0] * (1 - w) + x[i1] * w


def bvh_positions(bvh: Bvh, *, mapping: dict | None = None, scale: float | None = None,
                  up: str | None = None, fps: float = FPS, nose_forward: float = 0.10,
                  head_top_height: float = 0.18) -> np.ndarray:
    """(T, 10, 3) sgt joint positions in metres, y up, facing +z, at ``fps``."""
    idx = resolve_mapping(bvh, mapping)
    scale = detect_scale(bvh, idx) if scale is None else float(scale)
    up = detect_up(bvh, idx) if up is None else up
    pos, rot = forward_kinematics(bvh)
    r_up = _up_rotation(up)
    pos = np.einsum("ij,fkj->fki", r_up, pos) * scale
    rot = np.einsum("ij,fkjl->fkil", r_up, rot)
    # zero-pose frame, same axes: its face direction defines the head's local forward
    zp = np.einsum("ij,kj->ki", r_up, zero_pose_positions(bvh)) * scale
    # turn about y: shoulder line (right -> left) on +x, over the whole take
    lr = (pos[:, idx["left_shoulder"]] - pos[:, idx["right_shoulder"]]).mean(0)
    yaw = -math.atan2(-lr[2], lr[0])
    r_y = _rot_y(yaw)
    pos = np.einsum("ij,fkj->fki", r_y, pos)
    rot = np.einsum("ij,fkjl->fkil", r_y, rot)
    # zero pose: its own facing (left on +x after its own yaw); local forward of the head
    zlr = zp[idx["left_shoulder"]] - zp[idx["right_shoulder"]]
    zup = np.array([0.0, 1.0, 0.0])
    zfwd = np.cross(zlr, zup)
    zfwd[1] = 0.0
    zfwd = zfwd / max(np.linalg.norm(zfwd), 1e-9)
    # world rotation of the head at zero channels is the identity composed with r_up (no yaw)
    fwd = np.einsum("fij,j->fi", rot[:, idx["head"]], r_up.T @ zfwd)
    upv = np.einsum("fij,j->fi", rot[:, idx["head"]], r_up.T @ zup)
    head = pos[:, idx["head"]]
    nose = head + nose_forward * fwd + 0.02 * upv
    if "head_top" in idx:
        top = pos[:, idx["head_top"]]
        if np.linalg.norm(top - head, axis=-1).mean() < 1e-4:
            top = head + head_top_height * upv
    else:
        top = head + head_top_height * upv
    names = {"spine": pos[:, idx["spine"]], "neck": pos[:, idx["neck"]], "nose": nose, "head_top": top}
    for j in ("left_shoulder", "left_elbow", "left_wrist", "right_shoulder", "right_elbow", "right_wrist"):
        names[j] = pos[:, idx[j]]
    out = np.stack([names[j] for j in JOINTS], axis=1)
    return _resample(out, bvh.fps, fps)


def bvh_to_poses(path_or_bvh, **kwargs) -> np.ndarray:
    """Poses (T, 27) at FPS from a BVH file or :class:`Bvh` (keywords: see :func:`bvh_positions`)."""
    bvh = path_or_bvh if isinstance(path_or_bvh, Bvh) else read_bvh(path_or_bvh)
    return pose_from_positions(bvh_positions(bvh, **kwargs)).astype(np.float32)


# -- datasets -------------------------------------------------------------------------------


@dataclass
class Take:
    name: str
    bvh_path: Path
    audio_path: Path | None
    timings_path: Path | None


def find_takes(root) -> list[Take]:
    """Takes in a GENEA/Trinity layout (Motion/, Audio/, Transcripts/) or a flat BEAT-style folder."""
    root = Path(root)
    if not root.is_dir():
        raise LoaderError(f"{root} is not a folder")
    sub = {p.name.lower(): p for p in root.iterdir() if p.is_dir()}
    motion_dir = sub.get("motion", root)
    audio_dir = sub.get("audio", sub.get("wav", root))
    text_dir = sub.get("transcripts", sub.get("transcript", sub.get("textgrid", sub.get("text", root))))
    takes = []
    for bvh in sorted(motion_dir.glob("*.bvh")) + sorted(motion_dir.glob("*.BVH")):
        stem = bvh.stem
        audio = next((p for ext in (".wav", ".WAV", ".flac") for p in [audio_dir / f"{stem}{ext}"] if p.is_file()), None)
        timing = next((p for ext in (".TextGrid", ".textgrid", ".json") for p in [text_dir / f"{stem}{ext}"] if p.is_file()), None)
        takes.append(Take(stem, bvh, audio, timing))
    if not takes:
        raise LoaderError(f"no .bvh files in {motion_dir}")
    return takes


def load_take(take: Take, *, features: bool = True, **bvh_kwargs) -> dict:
    """One take as a corpus-style clip dict: poses, word timings and (optionally) model features."""
    poses = bvh_to_poses(take.bvh_path, **bvh_kwargs)
    n = len(poses)
    words = []
    if take.timings_path is not None:
        try:
            timed, _source = read_timings(take.timings_path)
        except SpeechError as exc:  # (its message names the file)
            raise LoaderError(str(exc)) from None
        words = [TimedWord(w, float(a), float(b)) for w, a, b in timed]
    clip = {"id": take.name, "poses": poses,
            "meta": {"text": " ".join(w.word for w in words), "words": [w.to_dict(6) for w in words], "source": "bvh",
                     "bvh": str(take.bvh_path), "audio": str(take.audio_path) if take.audio_path else None,
                     "n_frames": n}}
    if features:
        ids, onsets = word_features(words, n)
        clip["word_ids"], clip["onsets"] = ids, onsets
        if take.audio_path is not None:
            try:
                audio = load_audio(take.audio_path)
            except (OSError, RuntimeError, ValueError, EOFError) as exc:  # soundfile's errors are RuntimeErrors
                raise LoaderError(f"cannot read the audio {str(take.audio_path)!r}: {exc}") from None
            clip["audio"] = audio_features(audio, n)
    return clip


def load_folder(root, *, features: bool = True, progress=None, **bvh_kwargs) -> list[dict]:
    """Every take of a folder (see :func:`find_takes`) as clip dicts (see :func:`load_take`);
    ``progress(done, total, name)`` after each take."""
    takes = find_takes(root)
    clips = []
    for n, t in enumerate(takes):
        if progress:
            progress(n, len(takes), t.name)
        clips.append(load_take(t, features=features, **bvh_kwargs))
    if progress:
        progress(len(takes), len(takes), "")
    return clips

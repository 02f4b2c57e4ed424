"""Real speech-gesture data that users own, mapped onto sgt's 10-joint skeleton.

Supported: BVH motion + WAV audio + word timings (Praat TextGrid or JSON), as in the GENEA /
Trinity Speech-Gesture layout (``Motion/*.bvh``, ``Audio/*.wav``, ``Transcripts/*.json`` or
``*.TextGrid``) or BEAT-style flat folders (``NAME.bvh``, ``NAME.wav``, ``NAME.TextGrid``).
Timings files are read with :func:`dsl.speech.recording.read_timings` (TextGrid or
``[{"word", "start", "end"}]`` JSON).

BVH (:func:`read_bvh`): a regular file of at most ``LIMITS["motion capture"]`` bytes; the
hierarchy (offsets, channels, any Euler order, End Sites named ``PARENT_End``) and the motion,
strictly (a whole frame count that matches the numbers the file holds, a frame time of 0.1 ms to
1 s, finite values: anything else is a :class:`LoaderError` naming the file, and the line for a
value), forward kinematics to world positions, then (:func:`bvh_to_poses`):

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

from core.reading import InputFileError, open_input, read_bytes
from core.skeleton import BONE_NAMES, FPS, JOINTS, pose_from_positions
from core.words import TimedWord
from dsl.speech.recording import read_timings
from dsl.speech.types import SpeechError
from model.features import SAMPLE_RATE, audio_features, load_audio, word_features


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
    name: str = "<bvh>"  # the file, for messages

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
    """BVH bytes as whitespace-separated tokens, read in order (the hierarchy and the MOTION
    header: a few thousand tokens; the numbers after them are read by :func:`_numbers`);
    problems name the file."""

    def __init__(self, data: bytes, name: str) -> None:
        self.data = data
        self.toks = re.compile(rb"\S+").finditer(data)
        self.end = 0  # the offset just past the last token read
        self.name = name

    def error(self, message: str) -> LoaderError:
        return LoaderError(f"{self.name}: {message}")

    def error_at(self, offset: int, message: str) -> LoaderError:
        """An error at the line of byte ``offset``: ``FILE:LINE: message``."""
        line = self.data.count(b"\n", 0, offset) + 1
        return LoaderError(f"{self.name}:{line}: {message}")

    def next(self, what: str) -> str:
        m = next(self.toks, None)
        if m is None:
            raise self.error(f"the BVH file ends early (expected {what})")
        self.end = m.end()
        return m.group().decode("utf-8", errors="replace")

    def number(self, what: str) -> float:
        tok = self.next(what)
        try:
            value = float(tok)
        except ValueError:
            raise self.error(f"expected a number for {what}, found {tok!r}") from None
        if not math.isfinite(value):
            raise self.error(f"expected a finite number for {what}, found {tok!r}")
        return value

    def count(self, what: str, most: int) -> int:
        """A whole number from 0 to ``most`` (digits only: '1e9', '2.5' and '-1' are refused)."""
        tok = self.next(what)
        if not tok.isascii() or not tok.isdigit():
            raise self.error(f"expected a count (a whole number) for {what}, found {tok!r}")
        if len(tok) > 18 or int(tok) > most:
            raise self.error(f"{what} is {tok if len(tok) <= 18 else tok[:12] + f'... ({len(tok)} digits)'}; "
                             f"at most {most} are read")
        return int(tok)

    def rest(self) -> bytes:
        return self.data[self.end:]


def parse_bvh(text: str | bytes, name: str = "<bvh>") -> Bvh:
    """Parse BVH text or bytes (see module docstring); :class:`LoaderError` naming the file
    (and the line, for a value) for anything that is not a BVH take sgt can use."""
    toks = _Tokens(text.encode("utf-8") if isinstance(text, str) else text, name)
    if toks.next("HIERARCHY").upper() != "HIERARCHY":
        raise toks.error("not a BVH file (it must start with HIERARCHY)")
    joints, n_channels = _hierarchy(toks)
    frame_time, motion = _motion(toks, n_channels)
    _check_motion(toks, joints, motion)
    return Bvh(joints, frame_time, motion, name)


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
    count = toks.count(f"the channel count of joint {joint.name!r}", len(_CHANNEL_NAMES))
    chans = [toks.next("a channel name") for _ in range(count)]
    for c in chans:
        if c.lower() not in _CHANNEL_NAMES:
            raise toks.error(f"unknown channel {c!r} of joint {joint.name!r}")
    joint.channels, joint.channel_start = [c.lower() for c in chans], first
    return count


#: The frame times read, seconds: 1 to 10,000 frames a second.
FRAME_TIME_RANGE = (1e-4, 1.0)
#: The longest take read, seconds (its poses at :data:`FPS` are then at most 216,000 frames).
MAX_TAKE_SECONDS = 4 * 3600
#: The most joint-frames forward kinematics computes for a take (frames times the joints the
#: mapping needs, with their ancestors): 16.8 million, about 17 s at the measured 1 microsecond
#: each (20,000 frames through a 14-joint chain: 0.3 s). A take of the largest BVH file read
#: (512 MiB) has at most a million frames of 60 channels, through a chain of 12-15 joints. Memory
#: does not grow with it: the frames are computed in pieces (:data:`_FK_PIECE`).
MAX_JOINT_FRAMES = 1 << 24


def _motion(toks: _Tokens, n_channels: int) -> tuple[float, np.ndarray]:
    """The MOTION section: frame time and the (frames, channels) values. The declared frame
    count is checked against the numbers the file holds (nothing is sized by the declaration)."""
    if n_channels == 0:
        raise toks.error("the hierarchy has no CHANNELS, so the file holds no motion")
    if toks.next("Frames:").rstrip(":").lower() != "frames":
        raise toks.error("expected 'Frames:' after MOTION")
    n_frames = toks.count("the frame count", 10**12)
    if n_frames == 0:
        raise toks.error("'Frames: 0': the file holds no motion")
    if toks.next("Frame").lower() != "frame" or toks.next("Time:").rstrip(":").lower() != "time":
        raise toks.error("expected 'Frame Time:'")
    frame_time = toks.number("the frame time")
    low, high = FRAME_TIME_RANGE
    if not low <= frame_time <= high:
        raise toks.error(f"the frame time is {frame_time:g} s; it must be from {low:g} s to {high:g} s "
                         f"({1 / high:g} to {1 / low:g} frames a second)")
    if (n_frames - 1) * frame_time > MAX_TAKE_SECONDS:
        raise toks.error(f"'Frames: {n_frames}' at {frame_time:g} s a frame is {n_frames * frame_time / 3600:.1f} hours; "
                         f"a take may be at most {MAX_TAKE_SECONDS / 3600:g} hours: split it")
    start = toks.end
    values = _numbers(toks)
    need = n_frames * n_channels
    if len(values) != need:
        whole = len(values) // n_channels
        fix = f" (set 'Frames: {whole}')" if whole and len(values) % n_channels == 0 else ""
        raise toks.error_at(start, f"'Frames: {n_frames}' of {n_channels} channels needs {need} numbers; "
                                   f"the file has {len(values)}{fix}")
    return frame_time, values.reshape(n_frames, n_channels)


def _numbers(toks: _Tokens) -> np.ndarray:
    """Every number after the MOTION header (parsed by numpy, about 3 times faster than floats
    from a token list and without its memory); a token that is not a number: its line."""
    rest = toks.rest()
    if not re.search(rb"\S", rest):
        return np.zeros(0)
    try:
        return np.fromstring(rest, sep=" ")  # (numpy reads "  " alone as [-1]: handled above)
    except ValueError:  # the first token that is not a number, found again token by token
        for m in re.finditer(rb"\S+", rest):
            try:
                float(m.group())
            except ValueError:
                bad = m.group()[:40].decode("utf-8", errors="replace")
                raise toks.error_at(toks.end + m.start(), f"{bad!r} in the motion data is not a number") from None
        raise toks.error("the motion data has a value numpy cannot read as a number") from None


def _check_motion(toks: _Tokens, joints: list[BvhJoint], motion: np.ndarray) -> None:
    """A value that is not a finite number (nan, inf): its line, frame, joint and channel."""
    bad = ~np.isfinite(motion)
    if not bad.any():
        return
    frame, col = (int(x) for x in np.argwhere(bad)[0])
    joint = next(j for j in joints if j.channel_start <= col < j.channel_start + len(j.channels))
    channel = joint.channels[col - joint.channel_start]
    k = frame * motion.shape[1] + col  # the value's place among the numbers
    start = toks.end
    where = next(m.start() for i, m in enumerate(re.finditer(rb"\S+", toks.data[start:])) if i == k)
    raise toks.error_at(start + where, f"frame {frame}, {channel.capitalize()} of joint {joint.name!r} is {motion[frame, col]}; "
                                       "every value must be a finite number")


def read_bvh(path) -> Bvh:
    """A BVH file, read by :func:`core.reading.read_bytes` (a regular file of at most
    ``LIMITS["motion capture"]`` bytes: a FIFO or a device is refused without being read)."""
    p = Path(path)
    try:
        data = read_bytes(p, "motion capture")
    except InputFileError as e:
        raise LoaderError(f"{p}: {e.reason}") from None
    except IsADirectoryError:
        raise LoaderError(f"{p}: it is a folder, not a BVH file") from None
    except OSError as e:
        raise LoaderError(f"cannot read {str(p)!r}: {e.strerror or e}") from None
    return parse_bvh(data, str(p))


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


def forward_kinematics(bvh: Bvh, joints=None, frames: slice = slice(None)) -> tuple[np.ndarray, np.ndarray]:
    """World positions (F, K, 3) and rotations (F, K, 3, 3) of ``joints`` (K joint indices, in
    that order; default: every joint) over ``frames`` of the take, in the file's units and axes.
    Only those joints and their ancestors are computed.

    Rotation channels compose in the order listed (``Zrotation Xrotation Yrotation`` means
    R = Rz @ Rx @ Ry); position channels replace the joint's offset.
    """
    wanted = range(len(bvh.joints)) if joints is None else [int(i) for i in joints]
    motion = bvh.motion[frames]
    F = len(motion)
    world: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for i in _with_ancestors(bvh, wanted):
        j = bvh.joints[i]
        local_t = np.broadcast_to(j.offset, (F, 3)).copy()
        local_r = np.broadcast_to(np.eye(3), (F, 3, 3)).copy()
        for k, ch in enumerate(j.channels):
            v = motion[:, j.channel_start + k]
            if ch.endswith("position"):
                local_t[:, _AXIS[ch[0]]] = v
            else:
                local_r = local_r @ _axis_rot(_AXIS[ch[0]], v)
        if j.parent < 0:
            world[i] = local_t, local_r
        else:
            ppos, prot = world[j.parent]
            world[i] = ppos + np.einsum("fij,fj->fi", prot, local_t), prot @ local_r
    pos = np.zeros((F, len(wanted), 3))
    rot = np.zeros((F, len(wanted), 3, 3))
    for k, i in enumerate(wanted):
        pos[:, k], rot[:, k] = world[i]
    return pos, rot


def _with_ancestors(bvh: Bvh, joints) -> list[int]:
    """``joints`` and every ancestor of theirs, parents first (a BVH lists a joint after its
    parent, so that is their order in the file)."""
    out: set[int] = set()
    for i in joints:
        while i >= 0 and i not in out:
            out.add(i)
            i = bvh.joints[i].parent
    return sorted(out)


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


def _sample_times(n: int, src_fps: float, dst_fps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear interpolation of ``n`` samples at ``src_fps`` onto ``dst_fps``, from time 0: for
    each output frame the two source frames (i0, i1) and the weight of i1."""
    duration = (n - 1) / src_fps
    count = math.floor(duration * dst_fps + 1e-3) + 1
    t = np.arange(count) / dst_fps * src_fps
    i0 = np.clip(np.floor(t).astype(int), 0, n - 1)
    return i0, np.clip(i0 + 1, 0, n - 1), t - i0


#: Joint-frames of forward kinematics computed at a time (about 50 MB of arrays).
_FK_PIECE = 1 << 18


def bvh_positions(bvh: Bvh, *, mapping: dict | None = None, scale: float | None = None,
                  up: str | None = None, fps: float = FPS, nose_forward: float = 0.10,
                  head_top_height: float = 0.18) -> np.ndarray:
    """(T, 10, 3) sgt joint positions in metres, y up, facing +z, at ``fps`` (linear
    interpolation of the positions). Forward kinematics runs over the joints the mapping needs,
    a piece of the take at a time, keeping only the frames the resampling reads: memory does
    not grow with the file's joints, and the work is bounded by :data:`MAX_JOINT_FRAMES`."""
    idx = resolve_mapping(bvh, mapping)
    scale = detect_scale(bvh, idx) if scale is None else float(scale)
    up = detect_up(bvh, idx) if up is None else up
    r_up = _up_rotation(up)
    # zero-pose frame, same axes: its face direction defines the head's local forward
    zp = np.einsum("ij,kj->ki", r_up, zero_pose_positions(bvh)) * scale
    F = len(bvh.motion)
    if F == 0:
        return np.zeros((0, len(JOINTS), 3))
    names = list(idx)  # the sgt joints found, and their columns in the pieces
    col = {name: k for k, name in enumerate(names)}
    needed = [idx[name] for name in names]
    chain = len(_with_ancestors(bvh, needed))
    if F * chain > MAX_JOINT_FRAMES:
        raise LoaderError(f"{bvh.name}: {F} frames of {chain} joints (those the mapping needs, with their ancestors) "
                          f"are more than {MAX_JOINT_FRAMES} joint-frames to compute: split the take")
    i0, i1, w = _sample_times(F, bvh.fps, fps)
    keep = np.unique(np.concatenate([i0, i1]))  # the frames the resampling reads
    piece = max(1, _FK_PIECE // chain)
    lr_sum = np.zeros(3)
    kept_pos, kept_rot = [], []
    for a in range(0, F, piece):
        pos, rot = forward_kinematics(bvh, needed, slice(a, a + piece))
        pos = np.einsum("ij,fkj->fki", r_up, pos) * scale
        lr_sum += (pos[:, col["left_shoulder"]] - pos[:, col["right_shoulder"]]).sum(0)
        sel = keep[(keep >= a) & (keep < a + piece)] - a
        kept_pos.append(pos[sel])
        kept_rot.append(np.einsum("ij,fjl->fil", r_up, rot[sel, col["head"]]))
    pos, head_rot = np.concatenate(kept_pos), np.concatenate(kept_rot)
    # turn about y: shoulder line (right -> left) on +x, over the whole take
    lr = lr_sum / F
    yaw = -math.atan2(-lr[2], lr[0])
    r_y = _rot_y(yaw)
    pos = np.einsum("ij,fkj->fki", r_y, pos)
    head_rot = np.einsum("ij,fjl->fil", r_y, head_rot)
    # zero pose: its own facing (left on +x after its own yaw); local forward of the head
    zlr = zp[idx["left_shoulder"]] - zp[idx["right_shoulder"]]
    zup = np.array([0.0, 1.0, 0.0])
    zfwd = np.cross(zlr, zup)
    zfwd[1] = 0.0
    zfwd = zfwd / max(np.linalg.norm(zfwd), 1e-9)
    # world rotation of the head at zero channels is the identity composed with r_up (no yaw)
    fwd = np.einsum("fij,j->fi", head_rot, r_up.T @ zfwd)
    upv = np.einsum("fij,j->fi", head_rot, r_up.T @ zup)
    head = pos[:, col["head"]]
    nose = head + nose_forward * fwd + 0.02 * upv
    if "head_top" in idx:
        top = pos[:, col["head_top"]]
        if np.linalg.norm(top - head, axis=-1).mean() < 1e-4:
            top = head + head_top_height * upv
    else:
        top = head + head_top_height * upv
    at = {"spine": pos[:, col["spine"]], "neck": pos[:, col["neck"]], "nose": nose, "head_top": top}
    for j in ("left_shoulder", "left_elbow", "left_wrist", "right_shoulder", "right_elbow", "right_wrist"):
        at[j] = pos[:, col[j]]
    out = np.stack([at[j] for j in JOINTS], axis=1)
    j0, j1 = np.searchsorted(keep, i0), np.searchsorted(keep, i1)
    return out[j0] * (1 - w.reshape(-1, 1, 1)) + out[j1] * w.reshape(-1, 1, 1)


def bvh_to_poses(path_or_bvh, **kwargs) -> np.ndarray:
    """Poses (T, 27) at FPS from a BVH file or :class:`Bvh` (keywords: see :func:`bvh_positions`)."""
    bvh = path_or_bvh if isinstance(path_or_bvh, Bvh) else read_bvh(path_or_bvh)
    poses = pose_from_positions(bvh_positions(bvh, **kwargs)).astype(np.float32)
    length = np.linalg.norm(poses.reshape(len(poses), -1, 3), axis=-1)
    bad = ~(np.abs(length - 1) < 1e-3)  # a bone of length 0 (its joints coincide), or not a number
    if bad.any():
        frame, bone = (int(x) for x in np.argwhere(bad)[0])
        raise LoaderError(f"{bvh.name}: at {frame / kwargs.get('fps', FPS):.2f} s the {BONE_NAMES[bone]} bone has no "
                          "direction: its joints coincide, or the take's values are too large for positions")
    return poses


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
        # (any kind of file: a FIFO or a device named like the take's audio is refused by load_take, not skipped)
        audio = next((p for ext in (".wav", ".WAV", ".flac") for p in [audio_dir / f"{stem}{ext}"]
                      if p.exists() and not p.is_dir()), None)
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
            _check_audio(take.audio_path)
            try:
                audio = load_audio(take.audio_path)
            except (OSError, RuntimeError, ValueError, EOFError) as exc:  # soundfile's errors are RuntimeErrors
                raise LoaderError(f"cannot read the audio {str(take.audio_path)!r}: {exc}") from None
            bad = np.flatnonzero(~np.isfinite(audio))
            if len(bad):  # (a float WAV can hold nan or inf: its features, and the network, would be nan)
                raise LoaderError(f"{take.audio_path}: at {bad[0] / SAMPLE_RATE:.3f} s a sample is {audio[bad[0]]}, "
                                  "not a finite number")
            clip["audio"] = audio_features(audio, n)
    return clip


#: The sample rates of a take's audio read (Hz): resampling to the features' rate then makes at
#: most twice the samples, with a filter of at most a few million taps.
SAMPLE_RATES = (8000, 384000)


def _check_audio(path: Path) -> None:
    """LoaderError unless ``path`` is a regular file of at most ``LIMITS["audio"]`` bytes whose
    sample rate is in :data:`SAMPLE_RATES` (read from its header: a rate of 1 Hz would be
    resampled into 16,000 times its samples)."""
    import soundfile as sf

    try:
        with open_input(path, "audio"):
            pass
        rate = sf.info(str(path)).samplerate
    except InputFileError as exc:
        raise LoaderError(f"{path}: {exc.reason}") from None
    except (OSError, RuntimeError) as exc:  # soundfile's errors are RuntimeErrors
        raise LoaderError(f"cannot read the audio {str(path)!r}: {exc}") from None
    low, high = SAMPLE_RATES
    if not low <= rate <= high:
        raise LoaderError(f"{path}: a sample rate of {rate} Hz; audio from {low} to {high} Hz is read")


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

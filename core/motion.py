"""Motion files: a performance's utterances (poses with their text, words, controls and place
on the performance clock) and each speaker's continuous track (JSON or NPZ).

JSON (``*.json``)::

    {"format": "sgt-motion", "version": 3, "fps": 15,
     "joints": [...joint names], "bones": [[parent, child], ...],
     "coordinates": "y-up, right-handed, metres; character faces +z",
     "frames": N, "source": "mall_guide.sgt", "engine": "matching",
     "hands": {"sides": ["left", "right"], "digits": ["thumb", ...]},
     "face": {"names": [52 ARKit names], "eyes": ["left", "right"]},
     "utterances": [{"index": 0, "speaker": ..., "text": ...,
                     "start": 0.0, "audio_offset": 0.4,
                     "words": [{"word", "start", "end"}], "controls": [{...}],
                     "poses": [[27 floats], ...], "positions": [[[x, y, z] x 10], ...],
                     "hands": {"palm": [T x 2 x 3], "fingers": [T x 2 x 5 x 4]},
                     "face": {"weights": [T x 52], "gaze": [T x 2 x 2]}}],
     "tracks": [{"speaker": ..., "poses": [[27 floats] x N], "positions": [...],
                 "hands": {"palm": ..., "fingers": ...}, "face": {...}}]}

``start`` is the utterance's first motion frame in seconds on the performance clock (always a
whole frame), ``audio_offset`` the seconds from that frame to the first sample of its speech
audio; word times and control frames count from the utterance's own frame 0. A track is one
speaker's motion over the whole performance (``frames`` frames from time 0): its utterances
in their places, listening motion between them (see :mod:`model.performance`). ``source``
is the script it was generated from (relative to the motion file's folder when possible),
or null; ``engine`` the generation engine that made it (``matching``, ``neural``, ``keyframe``,
``rules``), or null where that is not known (a file from before the key, an export). Hands (:mod:`core.hands`: palm targets and finger angles in degrees per side and
frame) belong to every utterance and track.

The face (:mod:`core.face`: 52 ARKit blendshape weights in the header's ``face.names`` order
and each eye's yaw and pitch in degrees, per frame) is written for the utterances and tracks
that have one (``face`` None: the key is left out).

Floats are rounded to 5 decimals (hands: palms 4, finger angles 2; face weights 3, gaze 2).
NPZ (``*.npz``) holds ``poses_0``, ``positions_0``, ``hand_palm_0``, ``hand_fingers_0``,
``face_weights_0``, ``face_gaze_0``, ... and ``track_poses_0``, ``track_positions_0``,
``track_hand_palm_0``, ``track_hand_fingers_0``, ``track_face_weights_0``,
``track_face_gaze_0``, ... as float32 arrays plus ``meta``: the same JSON header without the
arrays. Version 2 files (no face) load with ``face`` None; version 1 files (no ``start``,
``audio_offset``, ``tracks``, hands) still load: their utterances are placed one after another
from 0, their audio offsets are unknown (None), they have no tracks and relaxed hands. Any
other format name or version is refused with :class:`MotionFileError`. Files are written by
:mod:`core.fileio`'s rules (atomically for a regular file: a temporary file in the same
folder, then ``os.replace``; a device or a link is never replaced).
"""

from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from core.controls import Control
from core.fileio import atomic_write
from core.frames_text import frame_lines_of_many, json_with_lines
from core.face import ARKIT_NAMES, EYES, FaceTrack
from core.hands import DIGITS, SIDES, HandTrack
from core.npz import load_npz
from core.reading import InputFileError, loads_json, read_bytes
from core.skeleton import BONE_NAMES, BONES, FPS, JOINTS, N_JOINTS, POSE_DIM, positions_from_pose
from core.words import TimedWord

FORMAT = "sgt-motion"
VERSION = 3
#: Versions this sgt reads: 1 (one clip after another, no tracks, no hands), 2 (no face) and 3.
READABLE_VERSIONS = (1, 2, 3)
COORDINATES = "y-up, right-handed, metres; character faces +z"


class MotionFileError(Exception):
    """A motion file that cannot be read or written."""


def _hands_for(hands, n_frames: int, owner: str) -> HandTrack:
    """``hands`` checked against ``n_frames`` poses; relaxed hands when None."""
    if hands is None:
        return HandTrack.rest(n_frames)
    if not isinstance(hands, HandTrack):
        raise TypeError(f"{owner}.hands must be core.hands.HandTrack")
    if hands.n_frames != n_frames:
        raise MotionFileError(f"hands have {hands.n_frames} frames, poses {n_frames}")
    return hands


@dataclass
class MotionClip:
    poses: np.ndarray
    fps: int = FPS
    speaker: str | None = None
    text: str | None = None
    words: list[TimedWord] = field(default_factory=list)  # seconds from the clip's frame 0
    controls: list[Control] = field(default_factory=list)
    positions: np.ndarray | None = None
    #: The hands on the same frames (relaxed when not given).
    hands: HandTrack | None = None
    index: int | None = None  # the script's utterance number (0-based)
    #: The face on the same frames (:class:`core.face.FaceTrack`); None: none was made.
    face: FaceTrack | None = None
    start: float = 0.0  # seconds on the performance clock of frame 0 (a whole frame)
    audio_offset: float | None = None  # seconds from frame 0 to the speech audio's first sample

    def __post_init__(self):
        p = np.asarray(self.poses, dtype=np.float32)
        if p.ndim != 2 or p.shape[1] != POSE_DIM:
            raise MotionFileError(f"poses must have shape (T, {POSE_DIM}), got {p.shape}")
        self.poses = p
        if not all(type(w) is TimedWord for w in self.words):
            raise TypeError("MotionClip.words must be core.words.TimedWord")
        if not all(isinstance(c, Control) for c in self.controls):
            raise TypeError("MotionClip.controls must be core.controls.Control")
        if self.positions is None:
            self.positions = positions_from_pose(p).astype(np.float32)
        else:
            self.positions = np.asarray(self.positions, dtype=np.float32)
        self.hands = _hands_for(self.hands, p.shape[0], "MotionClip")
        _check_face(self.face, p.shape[0], "MotionClip")

    @property
    def n_frames(self) -> int:
        return int(self.poses.shape[0])

    @property
    def start_frame(self) -> int:
        return int(round(self.start * FPS))


@dataclass
class Track:
    """One speaker's continuous motion over the whole performance, from time 0."""

    speaker: str | None
    poses: np.ndarray
    positions: np.ndarray | None = None
    #: The hands on the same frames (relaxed when not given).
    hands: HandTrack | None = None
    #: The face on the same frames (:class:`core.face.FaceTrack`); None: none was made.
    face: FaceTrack | None = None

    def __post_init__(self):
        self.poses = np.asarray(self.poses, dtype=np.float32)
        if self.poses.ndim != 2 or self.poses.shape[1] != POSE_DIM:
            raise MotionFileError(f"track poses must have shape (T, {POSE_DIM}), got {self.poses.shape}")
        self.hands = _hands_for(self.hands, self.poses.shape[0], "Track")
        _check_face(self.face, self.poses.shape[0], "Track")
        if self.positions is None:
            self.positions = positions_from_pose(self.poses).astype(np.float32)
        else:
            self.positions = np.asarray(self.positions, dtype=np.float32)

    @property
    def n_frames(self) -> int:
        return int(self.poses.shape[0])


def _check_face(face, n_frames: int, what: str) -> None:
    if face is not None and face.n_frames != n_frames:
        raise MotionFileError(f"{what} face has {face.n_frames} frames for {n_frames} poses")


@dataclass
class MotionFile:
    """What a motion file holds: the utterances, the speakers' tracks (none in version 1
    files) and the script it came from (a path from the current folder once read)."""

    clips: list[MotionClip]
    tracks: list[Track] = field(default_factory=list)
    source: str | None = None
    version: int = VERSION
    engine: str | None = None  # the engine that made it, where the file says


def _header() -> dict:
    return {
        "format": FORMAT,
        "version": VERSION,
        "fps": FPS,
        "joints": list(JOINTS),
        "bones": [list(b) for b in BONES],
        "coordinates": COORDINATES,
        "hands": {"sides": list(SIDES), "digits": list(DIGITS)},
        "face": {"names": list(ARKIT_NAMES), "eyes": list(EYES)},
    }


class _Rows:
    """An array written one frame per line in a motion JSON file, rounded to ``decimals``."""

    def __init__(self, array, decimals: int):
        self.array, self.decimals = np.asarray(array), decimals


def _frame_lines(rows: list[_Rows]):
    """A ``lines_of`` for :func:`json_with_lines`: the frame lines of ``rows`` (every array of
    the document), formatted in one pass per kind of array (poses, positions, palm, fingers),
    or json's numbers for an array the fast writer cannot write (empty, not finite)."""
    groups: dict[tuple, list[_Rows]] = {}
    for r in rows:
        groups.setdefault((r.decimals, r.array.shape[1:]), []).append(r)
    lines: dict[int, list[str]] = {}
    for (decimals, _), group in groups.items():
        for r, got in zip(group, frame_lines_of_many([r.array for r in group], decimals)):
            if got is None:
                got = [json.dumps(frame, separators=(",", ":"))
                       for frame in np.round(r.array.astype(np.float64), decimals).tolist()]
            lines[id(r)] = got
    return lambda x: lines[id(x)] if isinstance(x, _Rows) else None


def _utterance_meta(c: MotionClip) -> dict:
    return {
        "index": c.index,
        "speaker": c.speaker,
        "text": c.text,
        "start": round(c.start, 6),
        "audio_offset": None if c.audio_offset is None else round(c.audio_offset, 6),
        "words": [w.to_dict(4) for w in c.words],
        "controls": [x.to_dict() for x in c.controls],
    }


def _kind(path) -> str:
    if hasattr(path, "write"):
        raise MotionFileError("name the motion file format (json or npz) to write it to a stream")
    suffix = Path(path).suffix.lower()
    if suffix not in (".json", ".npz"):
        raise MotionFileError(f"{path}: unknown motion file type '{suffix}' (use .json or .npz)")
    return suffix[1:]


def _source_text(source, path) -> str | None:
    """The script's path as the motion file at ``path`` records it: relative to the file's
    folder (absolute for a stream)."""
    if source is None:
        return None
    if hasattr(path, "write"):
        return str(Path(source).resolve())
    return source_relative(source, path)


def source_relative(source, motion_path) -> str:
    """``source`` (a script's path) relative to the folder of the motion file ``motion_path``
    (absolute where no relative path exists, another drive)."""
    src = Path(source).resolve()
    try:
        return os.path.relpath(src, Path(motion_path).resolve().parent)
    except ValueError:  # another drive
        return str(src)


def save_motion(path, clips: Sequence[MotionClip], format: str | None = None, *,
                tracks: Sequence[Track] = (), source=None, engine: str | None = None, at=None) -> None:
    """Write ``clips`` (and the speakers' ``tracks``) to ``path`` by :mod:`core.fileio`'s rules
    (atomically for a regular file). ``source`` is the script's path, stored relative to the
    motion file's folder (``at``: where the file will be, when ``path`` is a stream whose bytes
    the caller writes there); ``engine`` the engine that made the motion.

    ``format`` ("json" or "npz") defaults to the path's extension; ``path`` may also be a binary
    stream (then ``format`` is needed)."""
    if format is None:
        kind = _kind(path)
    elif format in ("json", "npz"):
        kind = format
    else:
        raise MotionFileError(f"unknown motion file format '{format}' (use json or npz)")
    clips, tracks = list(clips), list(tracks)
    for c in clips:
        if c.fps != FPS:
            raise MotionFileError(f"clip at {c.fps} fps; motion files are {FPS} fps")
    frames = max([c.start_frame + c.n_frames for c in clips] + [t.n_frames for t in tracks] + [0])
    doc = {**_header(), "frames": frames, "source": _source_text(source, path if at is None else at), "engine": engine}
    if kind == "json":
        rows: list[_Rows] = []

        def arrays(part) -> dict:
            got = {"poses": _Rows(part.poses, 5), "positions": _Rows(part.positions, 5),
                   "hands": {key: _Rows(getattr(part.hands, key), d) for key, d in HandTrack.DECIMALS.items()}}
            rows.extend([got["poses"], got["positions"], *got["hands"].values()])
            if part.face is not None:
                got["face"] = {key: _Rows(getattr(part.face, key), d) for key, d in FaceTrack.DECIMALS.items()}
                rows.extend(got["face"].values())
            return got

        doc["utterances"] = [{**_utterance_meta(c), **arrays(c)} for c in clips]
        doc["tracks"] = [{"speaker": t.speaker, **arrays(t)} for t in tracks]
        data = (json_with_lines(doc, _frame_lines(rows)) + "\n").encode("utf-8")
    else:
        doc["utterances"] = [_utterance_meta(c) for c in clips]
        doc["tracks"] = [{"speaker": t.speaker} for t in tracks]
        arrays = {"meta": np.array(json.dumps(doc))}
        for prefix, parts in (("", clips), ("track_", tracks)):  # the names _npz_part reads
            for i, part in enumerate(parts):
                arrays[f"{prefix}poses_{i}"] = np.asarray(part.poses, dtype=np.float32)
                arrays[f"{prefix}positions_{i}"] = np.asarray(part.positions, dtype=np.float32)
                arrays[f"{prefix}hand_palm_{i}"] = part.hands.palm
                arrays[f"{prefix}hand_fingers_{i}"] = part.hands.fingers
                if part.face is not None:
                    arrays[f"{prefix}face_weights_{i}"] = part.face.weights
                    arrays[f"{prefix}face_gaze_{i}"] = part.face.gaze
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        data = buf.getvalue()
    atomic_write(path, data)


def _check_header(doc, path: Path) -> None:
    if not isinstance(doc, dict):
        raise MotionFileError(f"{path}: not an sgt motion file")
    if doc.get("format") != FORMAT:
        raise MotionFileError(f"{path}: format is {doc.get('format')!r}, expected '{FORMAT}'")
    if doc.get("version") not in READABLE_VERSIONS:
        raise MotionFileError(
            f"{path}: motion file version {doc.get('version')!r} is not supported "
            f"(this sgt reads versions {', '.join(map(str, READABLE_VERSIONS))})"
        )
    if doc.get("fps") != FPS:
        raise MotionFileError(f"{path}: fps {doc.get('fps')!r}, expected {FPS}")
    if doc.get("joints") != list(JOINTS):
        raise MotionFileError(f"{path}: joints do not match this skeleton")
    if not isinstance(doc.get("utterances"), list):
        raise MotionFileError(f"{path}: 'utterances' missing or not a list")
    if not isinstance(doc.get("tracks", []), list):
        raise MotionFileError(f"{path}: 'tracks' is not a list")


def _face(face, n_frames: int, names) -> FaceTrack | None:
    """A part's face read from a file (``{"weights", "gaze"}``, weights in ``names``' order),
    checked against its ``n_frames`` poses; None when the part has none. ValueError when it
    is malformed or not finite."""
    if face is None:
        return None
    if not isinstance(face, dict) or face.get("weights") is None or face.get("gaze") is None:
        raise ValueError("face must be an object with 'weights' and 'gaze'")
    if not isinstance(names, list) or len(set(names)) != len(names) or not all(isinstance(n, str) for n in names):
        raise ValueError("the header's face.names must be a list of distinct blendshape names")
    weights = np.asarray(face["weights"], dtype=np.float32)
    if weights.ndim != 2 or weights.shape[1] != len(names):
        raise ValueError(f"face weights have shape {weights.shape}, expected (frames, {len(names)})")
    got = FaceTrack.from_dict({"names": names, "weights": weights, "gaze": face["gaze"]})
    if got.n_frames != n_frames:
        raise ValueError(f"the face has {got.n_frames} frames for {n_frames} poses")
    for what, arr in (("face weight", got.weights), ("gaze", got.gaze)):
        bad = ~np.isfinite(arr)
        if bad.any():
            raise ValueError(f"the {what} at frame {np.argwhere(bad)[0][0]} is not a finite number")
    return got


def _clip(meta: dict, poses, positions, path: Path, i: int, hands=None, face=None, names=ARKIT_NAMES) -> MotionClip:
    if not isinstance(meta, dict):
        raise MotionFileError(f"{path}: utterance {i} is not an object")
    try:
        poses = np.asarray(poses, dtype=np.float32)
        if poses.ndim != 2 or poses.shape[1] != POSE_DIM:
            raise ValueError(f"poses have shape {poses.shape}, expected (T, {POSE_DIM})")
        if positions is not None:
            positions = np.asarray(positions, dtype=np.float32)
            if positions.shape != (poses.shape[0], N_JOINTS, 3):
                raise ValueError(f"positions have shape {positions.shape}")
        if isinstance(hands, dict):
            hands = HandTrack.from_dict(hands)
        elif hands is not None:
            raise ValueError("hands must be an object with 'palm' and 'fingers'")
        _check_values(poses, positions)
        face = _face(face, len(poses), list(names))
        offset = meta.get("audio_offset")
        return MotionClip(
            hands=hands,
            face=face,
            poses=poses,
            positions=positions,
            speaker=meta.get("speaker"),
            text=meta.get("text"),
            words=[TimedWord.from_dict(w) for w in meta.get("words") or []],
            controls=[Control.from_dict(x) for x in meta.get("controls") or []],
            index=int(meta["index"]) if meta.get("index") is not None else i,
            start=round(float(meta.get("start") or 0.0) * FPS) / FPS,  # a whole frame, rounded in the file
            audio_offset=None if offset is None else float(offset),
        )
    except (ValueError, TypeError, AttributeError) as exc:
        raise MotionFileError(f"{path}: utterance {i}: {exc}") from None


def _track(meta, poses, positions, path: Path, i: int, n_frames: int, hands=None, face=None, names=ARKIT_NAMES) -> Track:
    if not isinstance(meta, dict):
        raise MotionFileError(f"{path}: track {i} is not an object")
    try:
        poses = np.asarray(poses, dtype=np.float32)
        if poses.ndim != 2 or poses.shape != (n_frames, POSE_DIM):
            raise ValueError(f"poses have shape {poses.shape}, expected ({n_frames}, {POSE_DIM})")
        if positions is not None:
            positions = np.asarray(positions, dtype=np.float32)
            if positions.shape != (n_frames, N_JOINTS, 3):
                raise ValueError(f"positions have shape {positions.shape}")
        if isinstance(hands, dict):
            hands = HandTrack.from_dict(hands)
        elif hands is not None:
            raise ValueError("hands must be an object with 'palm' and 'fingers'")
        _check_values(poses, positions)
        return Track(meta.get("speaker"), poses, positions, hands, _face(face, n_frames, list(names)))
    except (ValueError, TypeError) as exc:
        raise MotionFileError(f"{path}: track {i}: {exc}") from None


def _check_values(poses: np.ndarray, positions) -> None:
    """ValueError, naming the first bad frame and joint, for a value that is not a finite number
    (NaN, Inf) or a bone direction of length 0: every writer after the load (BVH, glTF) would
    fail on it or write it on (hands: :class:`core.hands.HandTrack` checks them)."""
    def first_bad(arr: np.ndarray, what: str, names) -> None:
        bad = ~np.isfinite(arr)
        if bad.any():
            frame, *rest = np.argwhere(bad)[0]
            name = names[rest[0]] if names is not None and rest else None
            raise ValueError(f"{what} at frame {frame}{f' ({name})' if name else ''} is {arr[tuple([frame, *rest])]}, "
                             "not a finite number")

    first_bad(poses.reshape(len(poses), -1, 3), "the pose", BONE_NAMES)
    short = np.linalg.norm(poses.reshape(len(poses), -1, 3), axis=-1) < 1e-6
    if short.any():
        frame, bone = np.argwhere(short)[0]
        raise ValueError(f"the pose at frame {frame} ({BONE_NAMES[bone]}) has a bone direction of length 0")
    if positions is not None:
        first_bad(positions, "the position", JOINTS)


def _finish(doc: dict, clips: list[MotionClip], tracks: list[Track], path: Path) -> MotionFile:
    if doc["version"] == 1:  # before the performance clock: one after another, offsets unknown
        at = 0
        for c in clips:
            c.start, at = at / FPS, at + c.n_frames
    source = doc.get("source")
    if isinstance(source, str) and not hasattr(path, "write"):  # as the reader's paths go
        source = os.path.normpath(path.parent / source)
    engine = doc.get("engine")
    return MotionFile(clips, tracks, source if isinstance(source, str) else None, doc["version"],
                      engine if isinstance(engine, str) else None)


def load_motion(path) -> list[MotionClip]:
    """The utterances of a motion file written by :func:`save_motion`."""
    return load_motion_file(path).clips


def load_motion_file(path) -> MotionFile:
    """Everything a motion file written by :func:`save_motion` (any readable version) holds."""
    path = Path(path)
    kind = _kind(path)
    try:
        data = read_bytes(path, "motion file")  # a regular file of bounded size (a FIFO would hang np.load)
        if kind == "json":
            try:
                doc = loads_json(data)
            except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError, nesting
                raise MotionFileError(f"{path}: not valid JSON: {exc}") from None
            _check_header(doc, path)
            names = _face_names(doc)
            clips = [
                _clip(u, u.get("poses") if isinstance(u, dict) else None,
                      u.get("positions") if isinstance(u, dict) else None, path, i,
                      u.get("hands") if isinstance(u, dict) else None,
                      u.get("face") if isinstance(u, dict) else None, names)
                for i, u in enumerate(doc["utterances"])
            ]
            n = _frames(doc, clips, path)
            tracks = [
                _track(t, t.get("poses") if isinstance(t, dict) else None,
                       t.get("positions") if isinstance(t, dict) else None, path, i, n,
                       t.get("hands") if isinstance(t, dict) else None,
                       t.get("face") if isinstance(t, dict) else None, names)
                for i, t in enumerate(doc.get("tracks") or [])
            ]
            return _finish(doc, clips, tracks, path)
        try:
            z = load_npz(data, "motion file")  # sizes checked before anything is inflated (zip bombs)
            if "meta" not in z:
                raise MotionFileError(f"{path}: no 'meta' entry; not an sgt motion file")
            doc = loads_json(str(z["meta"]))
            _check_header(doc, path)
            names = _face_names(doc)
            clips = []
            for i, u in enumerate(doc["utterances"]):
                poses, pos, hands, face = _npz_part(z, "", i, path)
                clips.append(_clip(u, poses, pos, path, i, hands, face, names))
            n = _frames(doc, clips, path)
            tracks = []
            for i, t in enumerate(doc.get("tracks") or []):
                poses, pos, hands, face = _npz_part(z, "track_", i, path)
                tracks.append(_track(t, poses, pos, path, i, n, hands, face, names))
            return _finish(doc, clips, tracks, path)
        except (ValueError, KeyError) as exc:  # NpzError, JSON, a missing key
            raise MotionFileError(f"{path}: cannot read as npz: {exc or 'the file is empty'}") from None
    except FileNotFoundError:
        raise MotionFileError(f"{path}: no such file") from None
    except InputFileError as exc:
        raise MotionFileError(f"{path}: {exc.reason}") from None
    except IsADirectoryError:
        raise MotionFileError(f"{path}: it is a folder, not a motion file") from None
    except OSError as exc:
        raise MotionFileError(f"{path}: cannot read: {exc.strerror or exc}") from None


def _face_names(doc: dict) -> list:
    """The blendshape names of the file's face weights (the header's ``face.names``; ARKit's
    order when there is none)."""
    face = doc.get("face")
    return face.get("names") if isinstance(face, dict) and "names" in face else list(ARKIT_NAMES)


def _npz_part(z, prefix: str, i: int, path: Path) -> tuple:
    """(poses, positions or None, hands or None, face or None) of utterance ``i`` (``prefix``
    "") or track ``i`` (``prefix`` "track_") of an NPZ motion file."""
    def get(name: str):
        return z.get(f"{prefix}{name}_{i}")

    poses = get("poses")
    if poses is None:
        raise MotionFileError(f"{path}: missing {prefix}poses_{i}")
    palm, fingers = get("hand_palm"), get("hand_fingers")
    hands = {"palm": palm, "fingers": fingers} if palm is not None and fingers is not None else None
    weights, gaze = get("face_weights"), get("face_gaze")
    face = {"weights": weights, "gaze": gaze} if weights is not None or gaze is not None else None
    return poses, get("positions"), hands, face


def _frames(doc: dict, clips: list[MotionClip], path: Path) -> int:
    """The performance's length in frames (version 2), checked against its utterances."""
    if doc["version"] == 1:
        return 0
    n = doc.get("frames")
    if type(n) is not int or n < 0:
        raise MotionFileError(f"{path}: 'frames' must be a whole number of frames, not {n!r}")
    for i, c in enumerate(clips):
        if c.start < 0 or c.start_frame + c.n_frames > n:
            raise MotionFileError(f"{path}: utterance {i} (start {c.start:g} s, {c.n_frames} frames) "
                                  f"does not fit in the performance's {n} frames")
    return n

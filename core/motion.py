"""Motion files: utterances of poses with their text, words and controls (JSON or NPZ).

JSON (``*.json``)::

    {"format": "sgt-motion", "version": 1, "fps": 15,
     "joints": [...joint names], "bones": [[parent, child], ...],
     "coordinates": "y-up, right-handed, metres; character faces +z",
     "utterances": [{"speaker": ..., "text": ..., "words": [{"word", "start", "end"}],
                     "controls": [{...}], "poses": [[27 floats], ...],
                     "positions": [[[x, y, z] x 10], ...]}]}

Floats are rounded to 5 decimals. NPZ (``*.npz``) holds ``poses_0``, ``positions_0``, ...
as float32 arrays plus ``meta``: the same JSON header without the pose/position arrays.
Any other format name or version is refused with :class:`MotionFileError`. Files are
written by :mod:`core.fileio`'s rules (atomically for a regular file: a temporary file in
the same folder, then ``os.replace``; a device or a link is never replaced).
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from core.controls import Control
from core.fileio import atomic_write
from core.skeleton import BONES, FPS, JOINTS, N_JOINTS, POSE_DIM, positions_from_pose
from core.words import TimedWord

FORMAT = "sgt-motion"
VERSION = 1
COORDINATES = "y-up, right-handed, metres; character faces +z"


class MotionFileError(Exception):
    """A motion file that cannot be read or written."""


@dataclass
class MotionClip:
    poses: np.ndarray
    fps: int = FPS
    speaker: str | None = None
    text: str | None = None
    words: list[TimedWord] = field(default_factory=list)  # seconds from the clip's frame 0
    controls: list[Control] = field(default_factory=list)
    positions: np.ndarray | None = None

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

    @property
    def n_frames(self) -> int:
        return int(self.poses.shape[0])


def _header() -> dict:
    return {
        "format": FORMAT,
        "version": VERSION,
        "fps": FPS,
        "joints": list(JOINTS),
        "bones": [list(b) for b in BONES],
        "coordinates": COORDINATES,
    }


def _round(a: np.ndarray):
    return np.round(np.asarray(a, dtype=np.float64), 5).tolist()


def _utterance_meta(c: MotionClip) -> dict:
    return {
        "speaker": c.speaker,
        "text": c.text,
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


def save_motion(path, clips: Sequence[MotionClip], format: str | None = None) -> None:
    """Write ``clips`` to ``path`` by :mod:`core.fileio`'s rules (atomically for a regular file).

    ``format`` ("json" or "npz") defaults to the path's extension; ``path`` may also be a binary
    stream (then ``format`` is needed)."""
    if format is None:
        kind = _kind(path)
    elif format in ("json", "npz"):
        kind = format
    else:
        raise MotionFileError(f"unknown motion file format '{format}' (use json or npz)")
    clips = list(clips)
    for c in clips:
        if c.fps != FPS:
            raise MotionFileError(f"clip at {c.fps} fps; motion files are {FPS} fps")
    doc = _header()
    if kind == "json":
        doc["utterances"] = [
            {**_utterance_meta(c), "poses": _round(c.poses), "positions": _round(c.positions)}
            for c in clips
        ]
        data = (json.dumps(doc, indent=1) + "\n").encode("utf-8")
    else:
        doc["utterances"] = [_utterance_meta(c) for c in clips]
        arrays = {"meta": np.array(json.dumps(doc))}
        for i, c in enumerate(clips):
            arrays[f"poses_{i}"] = np.asarray(c.poses, dtype=np.float32)
            arrays[f"positions_{i}"] = np.asarray(c.positions, dtype=np.float32)
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        data = buf.getvalue()
    atomic_write(path, data)


def _check_header(doc, path: Path) -> None:
    if not isinstance(doc, dict):
        raise MotionFileError(f"{path}: not an sgt motion file")
    if doc.get("format") != FORMAT:
        raise MotionFileError(f"{path}: format is {doc.get('format')!r}, expected '{FORMAT}'")
    if doc.get("version") != VERSION:
        raise MotionFileError(
            f"{path}: motion file version {doc.get('version')!r} is not supported "
            f"(this sgt reads version {VERSION})"
        )
    if doc.get("fps") != FPS:
        raise MotionFileError(f"{path}: fps {doc.get('fps')!r}, expected {FPS}")
    if doc.get("joints") != list(JOINTS):
        raise MotionFileError(f"{path}: joints do not match this skeleton")
    if not isinstance(doc.get("utterances"), list):
        raise MotionFileError(f"{path}: 'utterances' missing or not a list")


def _clip(meta: dict, poses, positions, path: Path, i: int) -> MotionClip:
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
        return MotionClip(
            poses=poses,
            positions=positions,
            speaker=meta.get("speaker"),
            text=meta.get("text"),
            words=[TimedWord.from_dict(w) for w in meta.get("words") or []],
            controls=[Control.from_dict(x) for x in meta.get("controls") or []],
        )
    except (ValueError, TypeError, AttributeError) as exc:
        raise MotionFileError(f"{path}: utterance {i}: {exc}") from None


def load_motion(path) -> list[MotionClip]:
    """Read a motion file written by :func:`save_motion`."""
    path = Path(path)
    kind = _kind(path)
    try:
        if kind == "json":
            try:
                doc = json.loads(path.read_text(encoding="utf-8"))
            except json.JSONDecodeError as exc:
                raise MotionFileError(f"{path}: not valid JSON: {exc}") from None
            _check_header(doc, path)
            return [
                _clip(u, u.get("poses") if isinstance(u, dict) else None,
                      u.get("positions") if isinstance(u, dict) else None, path, i)
                for i, u in enumerate(doc["utterances"])
            ]
        try:
            with np.load(path, allow_pickle=False) as z:
                if "meta" not in z.files:
                    raise MotionFileError(f"{path}: no 'meta' entry; not an sgt motion file")
                doc = json.loads(str(z["meta"]))
                _check_header(doc, path)
                clips = []
                for i, u in enumerate(doc["utterances"]):
                    if f"poses_{i}" not in z.files:
                        raise MotionFileError(f"{path}: missing poses_{i}")
                    pos = z[f"positions_{i}"] if f"positions_{i}" in z.files else None
                    clips.append(_clip(u, z[f"poses_{i}"], pos, path, i))
                return clips
        except (ValueError, OSError, json.JSONDecodeError) as exc:
            if isinstance(exc, FileNotFoundError):
                raise
            raise MotionFileError(f"{path}: cannot read as npz: {exc}") from None
    except FileNotFoundError:
        raise MotionFileError(f"{path}: no such file") from None

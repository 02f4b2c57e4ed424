"""The motion library: unit gestures read from spec files, turned into clips.

::

    from library import load_library
    lib = load_library()
    clip = lib.get("point_right").clip(speed=2, flip=True, hold=0.5)
    clip.poses        # (T, 27) float32 unit bone directions at core.skeleton.FPS
    clip.stroke_frame # index into clip.poses, or None
    clip.hands        # core.hands.HandTrack: the hand shapes and palms, frame by frame

Built-in gestures live in ``library/gestures/``; user folders (see :mod:`library.config`
and ``extra_dirs``) come after it, and a later gesture with the same name overrides the
earlier one. Malformed files end up in ``Library.problems`` and are skipped. The spec
format is documented in :mod:`library.spec` and ``docs/library.md``.
"""

from __future__ import annotations

import os
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from core.hands import HandTrack, interpolate_hands, steady_palms
from core.skeleton import FPS, MIRROR_BONE_PERMUTATION, frame_count, mirror_pose, positions_from_pose
from library import retime
from library.config import configured_sources
from library.spec import GestureSpec, LibraryProblem, SpecError, interpolate, read_spec
from library.words import WORDS_FILE

__all__ = ["load_library", "Library", "Gesture", "Clip", "LibraryProblem", "BUILTIN_DIR"]

BUILTIN_DIR = Path(__file__).resolve().parent / "gestures"
BUILTIN = "built-in"


@dataclass(frozen=True)
class Clip:
    """A rendered gesture: poses (T, 27) float32 at FPS, the stroke frame (or None), and the
    bones it drives (9,) bool (:attr:`library.spec.GestureSpec.bone_mask`, mirrored with flip),
    and the hands (T frames)."""

    poses: np.ndarray
    stroke_frame: int | None
    hands: HandTrack
    bones: np.ndarray | None = None
    #: (2,) bool, :data:`core.hands.SIDES` order: the hands the gesture sets (mirrored with flip).
    hand_sides: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        return int(self.poses.shape[0])

    @property
    def duration(self) -> float:
        return self.n_frames / FPS


#: Clips each gesture keeps, by (speed, flip, hold): a script plays a few gestures many times,
#: and building a clip (retiming, mirroring, the hands) was half of checking a long script.
CLIPS_KEPT = 32


def _read_only(clip: Clip) -> Clip:
    """``clip`` with every array made read-only (it is shared: see :meth:`Gesture.clip`)."""
    for a in (clip.poses, clip.bones, clip.hand_sides, clip.hands.palm, clip.hands.fingers):
        if a is not None:
            a.setflags(write=False)
    return clip


class Gesture:
    """One unit gesture of the library."""

    def __init__(self, spec: GestureSpec, origin: str, overrides: Path | None = None):
        self.spec = spec
        self.origin = origin
        self.overrides = overrides
        self._base: dict[float, tuple[np.ndarray, HandTrack]] = {}
        self._keys: dict[float, np.ndarray] = {}
        self._clips: OrderedDict = OrderedDict()  # see CLIPS_KEPT

    name = property(lambda self: self.spec.name)
    description = property(lambda self: self.spec.description)
    tags = property(lambda self: list(self.spec.tags))
    duration = property(lambda self: self.spec.duration)
    path = property(lambda self: self.spec.path)
    keyframes = property(lambda self: self.spec.keyframes)

    def __repr__(self) -> str:
        return f"Gesture({self.name!r}, {self.duration:g}s, from {self.origin})"

    def _timeline(self) -> tuple[np.ndarray, np.ndarray]:
        """Keyframe times and full directions, with the held poses at 0 and ``duration`` added
        when the first keyframe is later or the last one earlier."""
        times = np.array([k.time for k in self.spec.keyframes])
        dirs = self.spec.key_dirs
        if times[0] > 0:
            times, dirs = np.concatenate([[0.0], times]), np.concatenate([dirs[:1], dirs])
        if times[-1] < self.duration:
            times, dirs = np.concatenate([times, [self.duration]]), np.concatenate([dirs, dirs[-1:]])
        return times, dirs

    def _frames(self, speed: float) -> np.ndarray:
        """The frames of :meth:`_timeline`'s keys at ``speed`` (:mod:`library.retime`), cached."""
        key = float(speed)
        frames = self._keys.get(key)
        if frames is None:
            times, dirs = self._timeline()
            if len(times) == 1:
                frames = np.array([0])
            else:
                frames = retime.key_frames(times, self.duration, dirs, lambda ts: interpolate(times, dirs, ts), speed)
            self._keys[key] = frames
        return frames

    def key_frames(self, speed: float = 1) -> np.ndarray:
        """The frame each spec keyframe lands on at ``speed``."""
        frames = self._frames(speed)
        first = 1 if self.spec.keyframes[0].time > 0 else 0
        return frames[first : first + len(self.spec.keyframes)]

    def n_frames(self, speed: float = 1) -> int:
        """Frames of the clip at ``speed``: ``frame_count(duration / speed)``, or more where the
        gesture cannot be played that fast within :data:`library.retime.MAX_DEG_PER_S`."""
        if len(self._timeline()[0]) == 1:
            return frame_count(self.duration / speed)
        return int(self._frames(speed)[-1]) + 1

    def stroke_frame(self, speed: float = 1) -> int | None:
        for i, k in enumerate(self.spec.keyframes):
            if k.stroke:
                return int(self.key_frames(speed)[i])
        return None

    def clip_length(self, speed: int = 1, hold: float = 0.0) -> int:
        """The number of frames of ``clip(speed, flip, hold)``, without building it."""
        return self.n_frames(speed) + (frame_count(hold) if hold > 0 else 0)

    def clip(self, speed: int = 1, flip: bool = False, hold: float = 0.0) -> Clip:
        """Play at ``speed`` x (length ~ duration/speed), mirrored if ``flip``.

        ``hold`` keeps the gesture's key pose ``hold`` more seconds (``frame_count(hold)``
        extra frames): the stroke pose, held right after the stroke and before the
        retraction, or the final pose when the spec marks no stroke.

        The clip is shared (the last :data:`CLIPS_KEPT` asked for are kept): its arrays are
        read-only, and whoever needs to change one copies it."""
        if not isinstance(speed, (int, float)) or isinstance(speed, bool) or speed <= 0:
            raise ValueError(f"speed must be a positive number, got {speed!r}")
        if not isinstance(hold, (int, float)) or hold < 0:
            raise ValueError(f"hold must be >= 0 seconds, got {hold!r}")
        kept = (float(speed), bool(flip), float(hold))
        clip = self._clips.get(kept)
        if clip is not None:
            self._clips.move_to_end(kept)
            return clip
        clip = self._clips[kept] = _read_only(self._clip(speed, flip, hold))
        while len(self._clips) > CLIPS_KEPT:
            self._clips.popitem(last=False)
        return clip

    def _clip(self, speed, flip: bool, hold: float) -> Clip:
        key = float(speed)
        base = self._base.get(key)
        if base is None:
            times, dirs = self._timeline()
            ts = np.zeros(self.n_frames(speed)) if len(times) == 1 else retime.frame_times(times, self._frames(speed))
            key_times = np.array([k.time for k in self.spec.keyframes])
            poses = interpolate(times, dirs, ts)
            hands = interpolate_hands(key_times, self.spec.key_palms, self.spec.key_fingers, ts)
            base = (poses, steady_palms(positions_from_pose(poses), hands))  # no hand flips through the forearm
            self._base[key] = base
        poses, hands = base
        bones, sides = self.spec.bone_mask, self.spec.hand_sides
        if flip:
            poses, hands = mirror_pose(poses), hands.mirrored()
            bones, sides = bones[MIRROR_BONE_PERMUTATION], sides[::-1]
        stroke = self.stroke_frame(speed)
        if hold > 0:
            at = len(poses) - 1 if stroke is None else stroke
            extra = np.repeat(poses[at : at + 1], frame_count(hold), axis=0)
            poses = np.concatenate([poses[: at + 1], extra, poses[at + 1 :]], axis=0)
            frames = np.concatenate([np.arange(at + 1), np.full(frame_count(hold), at), np.arange(at + 1, hands.n_frames)])
            hands = hands.take(frames)
        else:
            poses, hands = poses.copy(), hands.take(slice(None))
        return Clip(poses=np.ascontiguousarray(poses, dtype=np.float32), stroke_frame=stroke, hands=hands,
                    bones=bones.copy(), hand_sides=sides.copy())


@dataclass
class Library:
    """Gestures by name, plus the problems met while loading."""

    gestures: dict[str, Gesture] = field(default_factory=dict)
    problems: list[LibraryProblem] = field(default_factory=list)
    folders: list[tuple[str, Path]] = field(default_factory=list)

    def names(self) -> list[str]:
        return sorted(self.gestures)

    def get(self, name: str) -> Gesture | None:
        return self.gestures.get(name)

    def __contains__(self, name: str) -> bool:
        return name in self.gestures

    def __len__(self) -> int:
        return len(self.gestures)

    def __iter__(self):
        return (self.gestures[n] for n in self.names())

    def suggest(self, name: str) -> str | None:
        import difflib

        close = difflib.get_close_matches(name, self.names(), n=1, cutoff=0.6)
        return close[0] if close else None


# Parsed files by path -> (mtime_ns, size, GestureSpec | LibraryProblem).
_CACHE: dict[Path, tuple[int, int, object]] = {}


def _load_file(path: Path):
    try:
        st = path.stat()
    except OSError as exc:
        return LibraryProblem(path, "file", f"cannot read: {exc}")
    hit = _CACHE.get(path)
    if hit is not None and hit[0] == st.st_mtime_ns and hit[1] == st.st_size:
        return hit[2]
    try:
        result = read_spec(path)
    except SpecError as exc:
        result = LibraryProblem(path, exc.field, exc.message, exc.line, exc.col, exc.length, exc.suggestions)
    _CACHE[path] = (st.st_mtime_ns, st.st_size, result)
    return result


def load_library(extra_dirs: Sequence[Path] = (), *, use_config: bool = True) -> Library:
    """Load built-in gestures, then configured user folders, then ``extra_dirs``."""
    lib = Library()
    folders: list[tuple[str, Path]] = [(BUILTIN, BUILTIN_DIR)]
    named_by: dict[Path, str] = {}
    if use_config:
        user, probs = configured_sources()
        lib.problems += probs
        folders += [(str(p), Path(p)) for p, _ in user]
        named_by.update((Path(p), source) for p, source in user)
    folders += [(str(p), Path(p)) for p in extra_dirs]
    lib.folders = folders
    for origin, folder in folders:
        source = named_by.get(folder, "@library")
        try:
            entries = sorted(os.scandir(folder), key=lambda e: e.name)
        except FileNotFoundError:
            lib.problems.append(LibraryProblem(folder, "", "does not exist", kind="folder", source=source))
            continue
        except NotADirectoryError:
            lib.problems.append(LibraryProblem(folder, "", "is not a folder", kind="folder", source=source))
            continue
        except OSError as exc:
            lib.problems.append(LibraryProblem(folder, "", f"cannot be listed: {exc.strerror or exc}", kind="folder", source=source))
            continue
        for entry in entries:
            if not entry.name.endswith(".toml") or entry.name.startswith(".") or entry.name == WORDS_FILE:
                continue
            result = _load_file(Path(entry.path))
            if isinstance(result, LibraryProblem):
                lib.problems.append(result)
                continue
            previous = lib.gestures.get(result.name)
            lib.gestures[result.name] = Gesture(
                result, origin, overrides=previous.path if previous else None
            )
    return lib

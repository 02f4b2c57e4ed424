"""The motion library: unit gestures read from spec files, turned into clips.

::

    from library import load_library
    lib = load_library()
    clip = lib.get("point_right").clip(speed=2, flip=True, hold=0.5)
    clip.poses        # (T, 27) float32 unit bone directions at core.skeleton.FPS
    clip.stroke_frame # index into clip.poses, or None

Built-in gestures live in ``library/gestures/``; user folders (see :mod:`library.config`
and ``extra_dirs``) come after it, and a later gesture with the same name overrides the
earlier one. Malformed files end up in ``Library.problems`` and are skipped. The spec
format is documented in :mod:`library.spec` and ``docs/library.md``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from core.skeleton import FPS, frame_count, mirror_pose
from library.config import configured_sources
from library.spec import GestureSpec, LibraryProblem, SpecError, read_spec, sample

__all__ = ["load_library", "Library", "Gesture", "Clip", "LibraryProblem", "BUILTIN_DIR"]

BUILTIN_DIR = Path(__file__).resolve().parent / "gestures"
BUILTIN = "built-in"


@dataclass(frozen=True)
class Clip:
    """A rendered gesture: poses (T, 27) float32 at FPS, and the stroke frame (or None)."""

    poses: np.ndarray
    stroke_frame: int | None

    @property
    def n_frames(self) -> int:
        return int(self.poses.shape[0])

    @property
    def duration(self) -> float:
        return self.n_frames / FPS


class Gesture:
    """One unit gesture of the library."""

    def __init__(self, spec: GestureSpec, origin: str, overrides: Path | None = None):
        self.spec = spec
        self.origin = origin
        self.overrides = overrides
        self._base: dict[float, np.ndarray] = {}

    name = property(lambda self: self.spec.name)
    description = property(lambda self: self.spec.description)
    tags = property(lambda self: list(self.spec.tags))
    duration = property(lambda self: self.spec.duration)
    path = property(lambda self: self.spec.path)
    keyframes = property(lambda self: self.spec.keyframes)

    def __repr__(self) -> str:
        return f"Gesture({self.name!r}, {self.duration:g}s, from {self.origin})"

    def n_frames(self, speed: float = 1) -> int:
        return frame_count(self.duration / speed)

    def stroke_frame(self, speed: float = 1) -> int | None:
        t = self.spec.stroke_time
        if t is None:
            return None
        n = self.n_frames(speed)
        return int(round(t / self.duration * (n - 1))) if n > 1 else 0

    def clip_length(self, speed: int = 1, hold: float = 0.0) -> int:
        """The number of frames of ``clip(speed, flip, hold)``, without building it."""
        return self.n_frames(speed) + (frame_count(hold) if hold > 0 else 0)

    def clip(self, speed: int = 1, flip: bool = False, hold: float = 0.0) -> Clip:
        """Play at ``speed`` x (length ~ duration/speed), mirrored if ``flip``.

        ``hold`` keeps the gesture's key pose ``hold`` more seconds (``frame_count(hold)``
        extra frames): the stroke pose, held right after the stroke and before the
        retraction, or the final pose when the spec marks no stroke."""
        if not isinstance(speed, (int, float)) or isinstance(speed, bool) or speed <= 0:
            raise ValueError(f"speed must be a positive number, got {speed!r}")
        if not isinstance(hold, (int, float)) or hold < 0:
            raise ValueError(f"hold must be >= 0 seconds, got {hold!r}")
        key = float(speed)
        base = self._base.get(key)
        if base is None:
            base = sample(self.spec, self.n_frames(speed))
            self._base[key] = base
        poses = base
        if flip:
            poses = mirror_pose(poses)
        stroke = self.stroke_frame(speed)
        if hold > 0:
            at = len(poses) - 1 if stroke is None else stroke
            extra = np.repeat(poses[at : at + 1], frame_count(hold), axis=0)
            poses = np.concatenate([poses[: at + 1], extra, poses[at + 1 :]], axis=0)
        else:
            poses = poses.copy()
        return Clip(poses=np.ascontiguousarray(poses, dtype=np.float32), stroke_frame=stroke)


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
            if not entry.name.endswith(".toml") or entry.name.startswith("."):
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

"""Gesture spec files: parsing, validation and interpolation.

Spec file format (``library/gestures/NAME.toml``, one gesture per file)
=======================================================================

::

    name = "point_right"                 # required, [a-z][a-z0-9_]*, equals the file stem
    description = "Point to the character's right with the right hand."
    tags = ["deictic", "one-hand"]       # optional list of strings
    duration = 1.2                       # required, seconds at speed 1 (> 0)

    [[keyframes]]                        # at least one; times strictly increasing
    time = 0.0                           # seconds, inside [0, duration]
    label = "start"                      # optional free text ("prepare", "stroke", ...)

    [[keyframes]]
    time = 0.5
    label = "stroke"
    stroke = true                        # at most one keyframe of the file
    right_elbow = [-0.95, 0.1, 0.3]      # upper-arm direction (right shoulder -> elbow)
    right_wrist = [-0.9, 0.2, 0.4]       # forearm direction (right elbow -> wrist)

    [[keyframes]]
    time = 1.2
    right_elbow = "rest"                 # back to the rest direction
    right_wrist = "rest"

Bones are named after their child joint (see :data:`core.skeleton.BONE_NAMES`):
``neck`` (spine -> neck, the torso), ``nose`` and ``head_top`` (the head),
``left_shoulder``/``right_shoulder`` (neck -> shoulder), ``left_elbow``/``right_elbow``
(upper arms) and ``left_wrist``/``right_wrist`` (forearms). A bone value is either three
numbers (a direction in the skeleton's coordinates: y up, the character faces +z, its
left is +x; normalised on load, must not be zero) or the string ``"rest"``.

**Bones not given in a keyframe keep their value from the previous keyframe**; in the
first keyframe they take the rest pose. So a keyframe only lists what changes, and a
gesture that returns to rest says so with ``"rest"``.

Between keyframes each bone direction moves along the sphere on a spherical cubic
Bezier (slerp-based de Casteljau) with Catmull-Rom-like tangents: zero angular velocity at
the first and last keyframe and wherever the motion reverses, never overshooting a
keyframe. The result is always a unit vector, smooth, and takes the short way round.
Before the first keyframe and after the last, the pose is held. A clip at speed ``s``
has ``frame_count(duration / s)`` frames spread evenly from time 0 to ``duration``, so
the first and last frames are exactly the first and last keyframe poses.
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.skeleton import BONE_INDEX, BONE_NAMES, N_BONES, REST_POSE

NAME_RE = re.compile(r"[a-z][a-z0-9_]*\Z")
TOP_LEVEL_KEYS = ("name", "description", "tags", "duration", "keyframes")
KEYFRAME_KEYS = ("time", "label", "stroke")
#: Consecutive keyframe directions of one bone closer to opposite than this (degrees)
#: would make the interpolation ambiguous.
MAX_STEP_DEGREES = 170.0

REST_DIRS = np.asarray(REST_POSE, dtype=np.float64).reshape(N_BONES, 3)


@dataclass(frozen=True)
class LibraryProblem:
    """A malformed spec file, configuration file or gesture folder: where, which field, what is wrong.

    ``line`` and ``col`` (1-based; 0 for the whole file or folder) and ``length`` locate it in
    the TOML text; ``suggestions`` are close names for a misspelt key. ``kind`` says what
    ``path`` is: "spec" (a gesture file), "config" (a configuration file) or "folder" (a
    gesture folder, named by ``source``: SGT_LIBRARY_PATH, a configuration file, @library)."""

    path: Path
    field: str
    message: str
    line: int = 0
    col: int = 0
    length: int = 1
    suggestions: tuple[str, ...] = ()
    kind: str = "spec"
    source: str = ""

    def __str__(self) -> str:
        if self.kind == "folder":
            return f"gesture folder {self.path}" + (f" (from {self.source})" if self.source else "") + f" {self.message}"
        where = f"{self.path}"
        if self.line:
            where += f":{self.line}:{self.col}"
        if self.field:
            where += f": {self.field}"
        tail = ""
        if self.suggestions:
            tail = " (did you mean " + " or ".join(f"'{s}'" for s in self.suggestions) + "?)"
        return f"{where}: {self.message}{tail}"


@dataclass(frozen=True)
class Keyframe:
    time: float
    label: str | None
    stroke: bool
    #: Only the bones the file names: bone name -> unit direction, or None for "rest".
    bones: dict[str, tuple[float, float, float] | None]


@dataclass(frozen=True)
class GestureSpec:
    name: str
    description: str
    tags: tuple[str, ...]
    duration: float
    keyframes: tuple[Keyframe, ...]
    path: Path
    #: Full directions per keyframe, shape (K, 9, 3), after applying the defaults.
    key_dirs: np.ndarray = field(repr=False, compare=False)

    @property
    def stroke_time(self) -> float | None:
        for k in self.keyframes:
            if k.stroke:
                return k.time
        return None


class SpecError(Exception):
    """Raised internally while validating; carries the field it is about, close names for a
    misspelt key, and (once located in the text) its line, column and length."""

    def __init__(self, field: str, message: str, suggestions: tuple[str, ...] = ()):
        super().__init__(message)
        self.field = field
        self.message = message
        self.suggestions = suggestions
        self.line = self.col = 0
        self.length = 1


def _close(word: str, choices) -> tuple[str, ...]:
    return tuple(difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6))


_TOML_AT = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")
_TABLE_RE = re.compile(r"^\s*\[\[\s*([A-Za-z0-9_\-]+)\s*\]\]|^\s*\[\s*([A-Za-z0-9_\-.]+)\s*\]")


def toml_error(exc: tomllib.TOMLDecodeError) -> tuple[str, int, int]:
    """tomllib's message without its "(at line L, column C)" tail, and L and C (0, 0 if absent)."""
    text = str(exc)
    m = _TOML_AT.search(text)
    if m is None:
        return text, 0, 0
    return text[: m.start()], int(m.group(1)), int(m.group(2))


def locate(text: str, field: str) -> tuple[int, int, int]:
    """(line, col, length) of ``field`` ("duration", "keyframes[2].time", "keyframes") in a
    spec's TOML text: the key of that assignment, or the table header when the key is absent;
    (0, 0, 1) when it cannot be found (the problem is then about the whole file)."""
    m = re.fullmatch(r"(\w+)(?:\[(\d+)\])?(?:\.(\w+))?", field or "")
    if m is None:
        return 0, 0, 1
    table, index, key = m.group(1), m.group(2), m.group(3)
    lines = text.splitlines()
    if index is None and key is None:  # a top-level key, before the first table
        for n, line in enumerate(lines, start=1):
            if _TABLE_RE.match(line):
                break
            k = re.match(rf"\s*({re.escape(table)})\s*=", line)
            if k:
                return n, k.start(1) + 1, len(table)
        for n, line in enumerate(lines, start=1):  # "keyframes" itself: its first table
            t = _TABLE_RE.match(line)
            if t and (t.group(1) or t.group(2)) == table:
                return n, line.index(table) + 1, len(table)
        return 0, 0, 1
    count = -1
    header = None
    for n, line in enumerate(lines, start=1):
        t = _TABLE_RE.match(line)
        if t:
            if header is not None:
                break  # the next table: the key is not in this one
            if (t.group(1) or t.group(2)) == table:
                count += 1
                if count == int(index or 0):
                    header = (n, line.index(table) + 1, len(table))
            continue
        if header is not None and key is not None:
            k = re.match(rf"\s*({re.escape(key)})\s*=", line)
            if k:
                return n, k.start(1) + 1, len(key)
    return header or (0, 0, 1)


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def parse_spec_text(text: str, path: Path) -> GestureSpec:
    """Parse and validate one spec file's text. Raises :class:`SpecError`."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message, line, col = toml_error(exc)
        err = SpecError("toml", f"TOML syntax error: {message}")
        err.line, err.col = line, col
        raise err from None
    try:
        return _validate(data, path)
    except SpecError as exc:
        exc.line, exc.col, exc.length = locate(text, exc.field)
        raise


def _validate(data: dict, path: Path) -> GestureSpec:
    """A :class:`GestureSpec` from parsed TOML; the first problem raises :class:`SpecError`."""
    for key in data:
        if key not in TOP_LEVEL_KEYS:
            raise SpecError(key, f"unknown key '{key}'", _close(key, TOP_LEVEL_KEYS))
    name = _name(data, path)
    description, tags = _description_and_tags(data)
    duration = _duration(data)
    keyframes, key_dirs = _keyframes(data, duration)
    return GestureSpec(
        name=name,
        description=description,
        tags=tuple(tags),
        duration=duration,
        keyframes=tuple(keyframes),
        path=path,
        key_dirs=np.stack(key_dirs),
    )


def _name(data: dict, path: Path) -> str:
    if "name" not in data:
        raise SpecError("name", "missing 'name'")
    name = data["name"]
    if not isinstance(name, str) or not NAME_RE.match(name):
        raise SpecError(
            "name",
            f"name {name!r} must be lower-case letters, digits and '_', starting with a letter",
        )
    if name != path.stem:
        raise SpecError("name", f"name '{name}' does not match the file name '{path.name}'")
    return name


def _description_and_tags(data: dict) -> tuple[str, list[str]]:
    description = data.get("description", "")
    if not isinstance(description, str):
        raise SpecError("description", "description must be a string")
    tags = data.get("tags", [])
    if not isinstance(tags, list) or not all(isinstance(t, str) for t in tags):
        raise SpecError("tags", "tags must be a list of strings")
    return description, tags


def _duration(data: dict) -> float:
    if "duration" not in data:
        raise SpecError("duration", "missing 'duration' (seconds at speed 1)")
    duration = data["duration"]
    if not _is_number(duration) or duration <= 0:
        raise SpecError("duration", f"duration must be a positive number of seconds, got {duration!r}")
    return float(duration)


def _keyframes(data: dict, duration: float) -> tuple[list[Keyframe], list[np.ndarray]]:
    """The keyframes as written, and the full bone directions (9, 3) at each of them."""
    raw_keys = data.get("keyframes")
    if raw_keys is None:
        raise SpecError("keyframes", "missing [[keyframes]]")
    if not isinstance(raw_keys, list) or not raw_keys or not all(isinstance(k, dict) for k in raw_keys):
        raise SpecError("keyframes", "keyframes must be a non-empty array of tables ([[keyframes]])")
    keyframes: list[Keyframe] = []
    key_dirs: list[np.ndarray] = []
    dirs = REST_DIRS.copy()
    stroke_at: int | None = None
    for i, raw in enumerate(raw_keys):
        where = f"keyframes[{i}]"
        t = _key_time(where, raw, duration, keyframes[-1].time if keyframes else None)
        label = raw.get("label")
        if label is not None and not isinstance(label, str):
            raise SpecError(f"{where}.label", "label must be a string")
        stroke = _key_stroke(where, raw, stroke_at)
        if stroke:
            stroke_at = i
        bones, new_dirs = _key_bones(where, raw, dirs)
        if key_dirs:
            _check_turn(where, dirs, new_dirs)
        dirs = new_dirs
        key_dirs.append(dirs)
        keyframes.append(Keyframe(t, label, stroke, bones))
    return keyframes, key_dirs


def _key_time(where: str, raw: dict, duration: float, prev_time: float | None) -> float:
    if "time" not in raw:
        raise SpecError(f"{where}.time", "missing 'time'")
    t = raw["time"]
    if not _is_number(t):
        raise SpecError(f"{where}.time", f"time must be a number of seconds, got {t!r}")
    t = float(t)
    if t < 0 or t > duration + 1e-9:
        raise SpecError(f"{where}.time", f"time {t:g} is outside [0, duration={duration:g}]")
    if prev_time is not None and t <= prev_time:
        raise SpecError(
            f"{where}.time", f"time {t:g} is not after the previous keyframe's {prev_time:g}"
        )
    return t


def _key_stroke(where: str, raw: dict, stroke_at: int | None) -> bool:
    stroke = raw.get("stroke", False)
    if not isinstance(stroke, bool):
        raise SpecError(f"{where}.stroke", "stroke must be true or false")
    if stroke and stroke_at is not None:
        raise SpecError(
            f"{where}.stroke",
            f"second stroke keyframe (keyframes[{stroke_at}] is already the stroke)",
        )
    return stroke


def _key_bones(where: str, raw: dict, dirs: np.ndarray) -> tuple[dict, np.ndarray]:
    """The bones a keyframe names (unit direction, or None for "rest") and the full directions
    after it: bones it does not name keep ``dirs``."""
    bones: dict[str, tuple[float, float, float] | None] = {}
    new_dirs = dirs.copy()
    for key, value in raw.items():
        if key in KEYFRAME_KEYS:
            continue
        if key not in BONE_INDEX:
            if key == "spine":
                raise SpecError(f"{where}.{key}", "'spine' is the root joint and has no bone; use 'neck' to lean the torso")
            raise SpecError(f"{where}.{key}", f"unknown bone '{key}'", _close(key, BONE_NAMES + KEYFRAME_KEYS))
        if value == "rest":
            bones[key] = None
            new_dirs[BONE_INDEX[key]] = REST_DIRS[BONE_INDEX[key]]
            continue
        v = _direction(f"{where}.{key}", value)
        bones[key] = (float(v[0]), float(v[1]), float(v[2]))
        new_dirs[BONE_INDEX[key]] = v
    return bones, new_dirs


def _direction(field: str, value) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 3 or not all(_is_number(v) for v in value):
        raise SpecError(field, f"a bone direction must be 3 numbers or \"rest\", got {value!r}")
    v = np.asarray(value, dtype=np.float64)
    n = float(np.linalg.norm(v))
    if n < 1e-6:
        raise SpecError(field, "direction has zero length")
    return v / n


def _check_turn(where: str, dirs: np.ndarray, new_dirs: np.ndarray) -> None:
    cos = np.clip(np.sum(new_dirs * dirs, axis=1), -1.0, 1.0)
    worst = int(np.argmin(cos))
    angle = math.degrees(math.acos(cos[worst]))
    if angle > MAX_STEP_DEGREES:
        raise SpecError(
            f"{where}.{BONE_NAMES[worst]}",
            f"turns {angle:.0f} degrees from the previous keyframe; add a keyframe in between",
        )


def sample(spec: GestureSpec, n_frames: int) -> np.ndarray:
    """Sample ``n_frames`` poses (n_frames, 27) evenly over [0, duration]."""
    times = np.array([k.time for k in spec.keyframes])
    if n_frames == 1:
        ts = np.array([0.0])
    else:
        ts = np.linspace(0.0, spec.duration, n_frames)
    return interpolate(times, spec.key_dirs, ts)


def _log(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Log map on the unit sphere: the tangent vector at p pointing to q, length = angle."""
    c = np.clip(np.sum(p * q, axis=-1, keepdims=True), -1.0, 1.0)
    v = q - c * p
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-9, v / np.maximum(n, 1e-12) * np.arccos(c), 0.0)


def _exp(p: np.ndarray, v: np.ndarray) -> np.ndarray:
    a = np.linalg.norm(v, axis=-1, keepdims=True)
    out = p * np.cos(a) + np.where(a > 1e-12, v / np.maximum(a, 1e-12), 0.0) * np.sin(a)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def _slerp(a: np.ndarray, b: np.ndarray, u: np.ndarray) -> np.ndarray:
    return _exp(a, _log(a, b) * u)


def interpolate(times: np.ndarray, key_dirs: np.ndarray, ts: np.ndarray) -> np.ndarray:
    """Smooth interpolation of unit directions on the sphere.

    Each segment is a spherical cubic Bezier (de Casteljau with slerp) whose control
    points follow Catmull-Rom-like tangents: the mean of the angular velocities of the two
    neighbouring segments, zero at the first and last keyframe, and limited so that a
    segment never overshoots (control arms at most a third of the segment's angle when
    the motion reverses). Angles advance evenly, unlike renormalised straight chords.

    ``times`` (K,), ``key_dirs`` (K, B, 3), ``ts`` (T,) -> (T, B*3) float32.
    """
    times = np.asarray(times, dtype=np.float64)
    K = len(times)
    P = np.asarray(key_dirs, dtype=np.float64)
    P = P / np.linalg.norm(P, axis=-1, keepdims=True)
    if K == 1:
        out = np.repeat(P[None, 0], len(ts), axis=0)
        return out.reshape(len(ts), -1).astype(np.float32)
    h = np.diff(times)  # (K-1,)
    # Angular velocity (tangent at P[k], rad/s) at every keyframe.
    M = np.zeros_like(P)
    for k in range(1, K - 1):
        fwd = _log(P[k], P[k + 1]) / h[k]
        back = -_log(P[k], P[k - 1]) / h[k - 1]
        m = 0.5 * (fwd + back)
        # Where the motion reverses (e.g. the bottom of a beat), stop there.
        reverse = np.sum(fwd * back, axis=-1, keepdims=True) <= 0
        M[k] = np.where(reverse, 0.0, m)
    # Bezier control points of each segment, arms limited to a third of the segment angle.
    A = P[:-1]
    D = P[1:]
    seg_angle = np.linalg.norm(_log(A, D), axis=-1, keepdims=True)  # (K-1, B, 1)

    def _limit(v, limit):
        n = np.linalg.norm(v, axis=-1, keepdims=True)
        return v * np.minimum(1.0, limit / np.maximum(n, 1e-12))

    arm_out = _limit(M[:-1] * (h[:, None, None] / 3.0), seg_angle / 3.0)
    arm_in = _limit(M[1:] * (h[:, None, None] / 3.0), seg_angle / 3.0)
    B_ = _exp(A, arm_out)
    C_ = _exp(D, -_transport(P[1:], arm_in))

    tc = np.clip(np.asarray(ts, dtype=np.float64), times[0], times[-1])
    seg = np.clip(np.searchsorted(times, tc, side="right") - 1, 0, K - 2)
    u = ((tc - times[seg]) / h[seg])[:, None, None]
    a, b, c, d = A[seg], B_[seg], C_[seg], D[seg]
    ab, bc, cd = _slerp(a, b, u), _slerp(b, c, u), _slerp(c, d, u)
    abc, bcd = _slerp(ab, bc, u), _slerp(bc, cd, u)
    out = _slerp(abc, bcd, u)
    return out.reshape(len(ts), -1).astype(np.float32)


def _transport(p: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Keep only the part of v tangent to the sphere at p."""
    return v - np.sum(v * p, axis=-1, keepdims=True) * p


def read_spec(path: Path) -> GestureSpec:
    """Read and validate one spec file. Raises :class:`SpecError` (field 'file' for I/O)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError("file", f"cannot read: {exc}") from None
    return parse_spec_text(text, Path(path))

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
    right_hand = "relaxed"               # optional: a hand shape (core.hands.SHAPES)
    right_palm = "in"                    # optional: where the palm faces (core.hands.PALMS)

Bones are named after their child joint (see :data:`core.skeleton.BONE_NAMES`):
``neck`` (spine -> neck, the torso), ``nose`` and ``head_top`` (the head),
``left_shoulder``/``right_shoulder`` (neck -> shoulder), ``left_elbow``/``right_elbow``
(upper arms) and ``left_wrist``/``right_wrist`` (forearms). A bone value is either three
numbers (a direction in the skeleton's coordinates: y up, the character faces +z, its
left is +x; normalised on load, must not be zero) or the string ``"rest"``.

**Bones not given in a keyframe keep their value from the previous keyframe**; in the
first keyframe they take the rest pose. So a keyframe only lists what changes, and a
gesture that returns to rest says so with ``"rest"``.

Hands (optional, per keyframe): ``right_hand`` / ``left_hand`` name a shape of
:data:`core.hands.SHAPES` ("relaxed", "open", "fist", "point", "thumb_up", "thumb_down",
"ok", "pinch", "count1" .. "count5") and ``right_palm`` / ``left_palm`` a palm direction of
:data:`core.hands.PALMS` ("down", "up", "in" towards the body's midline, "out" away from it,
"forward" towards the listener, "back" towards the speaker). Like bones, a keyframe that
does not name them keeps the previous keyframe's; the first takes the rest hand (relaxed,
palm in). Between keyframes hands ease from one keyframe to the next
(:func:`core.hands.interpolate_hands`); ``flip`` mirrors them with the body.

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

from core.hands import PALMS, REST_PALM, REST_SHAPE, SHAPE_ANGLES, SHAPES, SIDES, HandTrack, interpolate_hands, palm_direction
from core.reading import InputFileError, read_bytes
from core.skeleton import BONE_INDEX, BONE_NAMES, N_BONES, REST_POSE, mirror_name

NAME_RE = re.compile(r"[a-z][a-z0-9_]*\Z")
TOP_LEVEL_KEYS = ("name", "description", "tags", "duration", "variant_of", "keyframes")
KEYFRAME_KEYS = ("time", "label", "stroke")
#: Optional hand keys of a keyframe: a shape name (``*_hand``) or a palm direction (``*_palm``).
HAND_KEYS = ("left_hand", "right_hand", "left_palm", "right_palm")
#: Consecutive keyframe directions of one bone closer to opposite than this (degrees)
#: would make the interpolation ambiguous.
MAX_STEP_DEGREES = 170.0
#: The longest gesture, seconds at speed 1 (the longest built-in one, think, is 2 s), and the
#: most keyframes one may have: a spec beyond them is refused by the spec checker, so that
#: `sgt check` and `sgt generate` agree (200,000 keyframes passed check, then generation asked
#: for 3 GiB; duration = 1e300 overflowed into 13 frames).
MAX_DURATION = 10.0
MAX_KEYFRAMES = 150

REST_DIRS = np.asarray(REST_POSE, dtype=np.float64).reshape(N_BONES, 3)

#: The limbs a gesture drives, by the bones they hold. A gesture drives every limb one of
#: whose bones a keyframe names (even as "rest"), and leaves the others to the generator.
LIMBS: dict[str, tuple[str, ...]] = {
    "torso": ("neck",),
    "head": ("nose", "head_top"),
    "left_arm": ("left_shoulder", "left_elbow", "left_wrist"),
    "right_arm": ("right_shoulder", "right_elbow", "right_wrist"),
}
LIMB_OF = {bone: limb for limb, bones in LIMBS.items() for bone in bones}


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
    #: Only the hand keys the file names (:data:`HAND_KEYS`): key -> shape or palm name.
    hands: dict[str, str] = field(default_factory=dict)

    def mirrored(self) -> "Keyframe":
        """The keyframe of the gesture played with ``flip``: left and right bones swapped, x negated."""
        bones = {mirror_name(b): (None if v is None else (-v[0], v[1], v[2])) for b, v in self.bones.items()}
        hands = {mirror_name(k): v for k, v in self.hands.items()}  # palm names are relative to each hand
        return Keyframe(self.time, self.label, self.stroke, bones, hands)


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
    #: Hands per keyframe after the defaults: palm targets (K, 2, 3) and finger angles
    #: (K, 2, 5, 4), side order :data:`core.hands.SIDES`.
    key_palms: np.ndarray = field(default=None, repr=False, compare=False)
    key_fingers: np.ndarray = field(default=None, repr=False, compare=False)
    #: The gesture this one is a deliberate variant of (its stroke may look alike), or None.
    variant_of: str | None = None

    @property
    def limbs(self) -> tuple[str, ...]:
        """The limbs (:data:`LIMBS`) the gesture drives: those with a bone some keyframe names."""
        named = {b for k in self.keyframes for b in k.bones}
        return tuple(limb for limb, bones in LIMBS.items() if named.intersection(bones))

    @property
    def hand_sides(self) -> np.ndarray:
        """(2,) bool in :data:`core.hands.SIDES` order: the hands the gesture sets, those of the
        arms it drives and those its keyframes name a shape or palm for."""
        limbs = set(self.limbs)
        named = {key.split("_")[0] for k in self.keyframes for key in k.hands}
        return np.array([f"{side}_arm" in limbs or side in named for side in SIDES])

    @property
    def bone_mask(self) -> np.ndarray:
        """(9,) bool in :data:`core.skeleton.BONE_NAMES` order: the bones the gesture drives."""
        limbs = set(self.limbs)
        return np.array([LIMB_OF[b] in limbs for b in BONE_NAMES])


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
    variant_of = data.get("variant_of")
    if variant_of is not None and (not isinstance(variant_of, str) or not NAME_RE.match(variant_of)):
        raise SpecError("variant_of", f"variant_of must name a gesture (lower-case letters, digits and '_'), got {variant_of!r}")
    key_palms, key_fingers = _key_hands(keyframes)
    return GestureSpec(
        name=name,
        description=description,
        tags=tuple(tags),
        duration=duration,
        keyframes=tuple(keyframes),
        path=path,
        key_dirs=np.stack(key_dirs),
        variant_of=variant_of,
        key_palms=key_palms,
        key_fingers=key_fingers,
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
    if duration > MAX_DURATION:
        raise SpecError("duration", f"duration {duration:g} s is longer than a gesture may be ({MAX_DURATION:g} s); "
                                    "split it into gestures, or hold its end with hold=")
    return float(duration)


def _keyframes(data: dict, duration: float) -> tuple[list[Keyframe], list[np.ndarray]]:
    """The keyframes as written, and the full bone directions (9, 3) at each of them."""
    raw_keys = data.get("keyframes")
    if raw_keys is None:
        raise SpecError("keyframes", "missing [[keyframes]]")
    if not isinstance(raw_keys, list) or not raw_keys or not all(isinstance(k, dict) for k in raw_keys):
        raise SpecError("keyframes", "keyframes must be a non-empty array of tables ([[keyframes]])")
    if len(raw_keys) > MAX_KEYFRAMES:
        raise SpecError("keyframes", f"{len(raw_keys)} keyframes; a gesture may have at most {MAX_KEYFRAMES} "
                                     f"(one per frame of the longest gesture, {MAX_DURATION:g} s)")
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
        keyframes.append(Keyframe(t, label, stroke, bones, _hand_names(where, raw)))
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
        if key in KEYFRAME_KEYS or key in HAND_KEYS:
            continue
        if key not in BONE_INDEX:
            if key == "spine":
                raise SpecError(f"{where}.{key}", "'spine' is the root joint and has no bone; use 'neck' to lean the torso")
            raise SpecError(f"{where}.{key}", f"unknown bone '{key}'", _close(key, BONE_NAMES + KEYFRAME_KEYS + HAND_KEYS))
        if value == "rest":
            bones[key] = None
            new_dirs[BONE_INDEX[key]] = REST_DIRS[BONE_INDEX[key]]
            continue
        v = _direction(f"{where}.{key}", value)
        bones[key] = (float(v[0]), float(v[1]), float(v[2]))
        new_dirs[BONE_INDEX[key]] = v
    return bones, new_dirs


def _hand_names(where: str, raw: dict) -> dict[str, str]:
    """The hand keys a keyframe names, checked against the shape and palm vocabularies."""
    out = {}
    for key in HAND_KEYS:
        if key not in raw:
            continue
        value = raw[key]
        names, what = (SHAPES, "hand shape") if key.endswith("_hand") else (PALMS, "palm direction")
        if not isinstance(value, str):
            raise SpecError(f"{where}.{key}", f"{key} must be a {what} name in quotes, one of {', '.join(names)}; got {value!r}")
        if value not in names:
            raise SpecError(f"{where}.{key}", f"unknown {what} '{value}' (one of {', '.join(names)})", _close(value, names))
        out[key] = value
    return out


def _key_hands(keyframes: list[Keyframe]) -> tuple[np.ndarray, np.ndarray]:
    """Palm targets (K, 2, 3) and finger angles (K, 2, 5, 4) at every keyframe: what it names,
    else the previous keyframe's, else the rest hand."""
    palms = np.stack([palm_direction(REST_PALM, side) for side in SIDES])
    fingers = np.stack([SHAPE_ANGLES[REST_SHAPE]] * 2).astype(np.float64)
    key_palms, key_fingers = [], []
    for k in keyframes:
        palms, fingers = palms.copy(), fingers.copy()
        for s, side in enumerate(SIDES):
            if f"{side}_palm" in k.hands:
                palms[s] = palm_direction(k.hands[f"{side}_palm"], side)
            if f"{side}_hand" in k.hands:
                fingers[s] = SHAPE_ANGLES[k.hands[f"{side}_hand"]]
        key_palms.append(palms)
        key_fingers.append(fingers)
    return np.stack(key_palms), np.stack(key_fingers)


def sample_hands(spec: GestureSpec, n_frames: int) -> HandTrack:
    """The gesture's hands at ``n_frames`` frames spread evenly over [0, duration], as :func:`sample`."""
    times = np.array([k.time for k in spec.keyframes])
    ts = np.array([0.0]) if n_frames == 1 else np.linspace(0.0, spec.duration, n_frames)
    return interpolate_hands(times, spec.key_palms, spec.key_fingers, ts)


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
        text = read_bytes(path, "gesture spec").decode("utf-8")
    except InputFileError as exc:
        raise SpecError("file", f"cannot read: {exc.reason}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError("file", f"cannot read: {exc}") from None
    return parse_spec_text(text, Path(path))

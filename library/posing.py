"""A gesture being made by hand, and its spec file (``sgt view``'s pose editor; a terminal pose
mode may use it too).

A :class:`Draft` holds what an editor poses: keyframes (:class:`PoseKey`) with their times,
labels and the stroke mark, each with the **whole** pose (27 numbers: the unit bone directions
of :mod:`core.skeleton`) and both hands by name (shape and palm, :mod:`core.hands`), and the
limbs the gesture drives (:data:`library.spec.LIMBS`: a limb is driven when some keyframe moves
one of its bones off the rest pose, or when the editor says so, to hold it at rest).

:meth:`Draft.spec_text` is the spec file ``library/gestures/*.toml`` use (docs/library.md):
a keyframe names the bones of the driven limbs that differ from what the file holds at that
point (the previous keyframe's, the rest pose in the first; ``"rest"`` for the rest
direction) and the hand names that differ from the previous keyframe's. Directions are written
with every digit (Python's shortest repr), after :meth:`Draft.canonical` made each of them a
vector that the spec reader's normalisation leaves as it is: what :func:`library.spec.parse_spec_text`
(and so ``sgt library show NAME``) reads back is exactly the keyframes saved, and a draft read back
from the file (:meth:`Draft.from_spec`) writes the same text again.

:meth:`Draft.mirrored` is the library's ``flip`` (:func:`core.skeleton.mirror_pose`, the hands'
sides swapped). :func:`save` writes a draft into a gesture folder atomically, inside the folder
(:class:`core.fileio.Inside`: no link followed), refusing over an existing gesture unless asked to
replace it, and never over a file that changed since its reader saw it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.fileio import Inside, OutputExists
from core.hands import PALMS, REST_PALM, REST_SHAPE, SHAPES, HandTrack, hand_positions
from core.reading import LIMITS
from core.skeleton import BONE_INDEX, BONE_NAMES, N_BONES, POSE_DIM, mirror_name, mirror_pose, positions_from_pose
from library.extract import _num, _toml_str
from library.spec import (
    LIMB_OF,
    LIMBS,
    MAX_DURATION,
    MAX_KEYFRAMES,
    NAME_RE,
    REST_DIRS,
    GestureSpec,
    SpecError,
    parse_spec_text,
)

#: A keyframe's hands, by name: every key, always (the file names only those that change).
HAND_ORDER = ("left_hand", "left_palm", "right_hand", "right_palm")
REST_HANDS = {"left_hand": REST_SHAPE, "left_palm": REST_PALM, "right_hand": REST_SHAPE, "right_palm": REST_PALM}
#: The labels the library's specs give their keyframes (an editor offers them; any text is allowed).
LABELS = ("start", "prepare", "stroke", "hold", "retract")
#: Keyframe times are kept to the microsecond (the file writes six decimals).
TIME_DECIMALS = 6
MAX_TEXT = 500  # characters of a description or a label
MAX_TAGS = 20


class DraftError(ValueError):
    """A draft that cannot be a gesture (from a page's request, or refused by the spec reader):
    ``str()`` is one line."""


class GestureExists(DraftError):
    """:func:`save` without ``replace`` over a gesture of that name; ``sha256`` is the file's in
    the folder (None when the gesture lives elsewhere: a built-in, another folder)."""

    def __init__(self, message: str, sha256: str | None) -> None:
        super().__init__(message)
        self.sha256 = sha256


class FileChanged(DraftError):
    """:func:`save` over a file that is not the one its reader saw (its SHA-256 differs)."""


def joints_of(pose, hands: dict[str, str]) -> tuple[np.ndarray, np.ndarray]:
    """One pose's joints (10, 3) and its hands' joints (2, 20, 3), the hands by name (:data:`HAND_ORDER`)."""
    positions = positions_from_pose(np.asarray(pose, np.float64))
    track = HandTrack.constant(1, (hands["left_hand"], hands["right_hand"]), (hands["left_palm"], hands["right_palm"]))
    return positions, hand_positions(positions[None], track)[0]


def rest_pose() -> np.ndarray:
    """The rest pose (27,) float64, exactly as the spec reader holds it (``"rest"``)."""
    return REST_DIRS.reshape(-1).copy()


@dataclass
class PoseKey:
    """One keyframe: its time (seconds), the whole pose (27,) float64 and both hands by name."""

    time: float
    pose: np.ndarray
    hands: dict[str, str] = field(default_factory=lambda: dict(REST_HANDS))
    label: str = ""
    stroke: bool = False


@dataclass
class Draft:
    """A gesture being posed (the module's docstring)."""

    name: str
    duration: float
    keys: list[PoseKey]
    description: str = ""
    tags: tuple[str, ...] = ()
    #: Limbs driven even where they stay at rest (a loaded gesture's ``"rest"`` arm, a box ticked).
    drives: frozenset[str] = frozenset()
    variant_of: str | None = None

    # -- what the file says ----------------------------------------------------------------

    def driven(self) -> tuple[str, ...]:
        """The limbs the gesture drives, in :data:`LIMBS` order: those of :attr:`drives` and
        those with a bone off the rest pose in some keyframe."""
        moved = set(self.drives)
        for key in self.keys:
            dirs = key.pose.reshape(N_BONES, 3)
            moved.update(LIMB_OF[b] for b in BONE_NAMES if not np.array_equal(dirs[BONE_INDEX[b]], REST_DIRS[BONE_INDEX[b]]))
        return tuple(limb for limb in LIMBS if limb in moved)

    def spec_text(self) -> str:
        """The spec file of this draft as it is (see :meth:`canonical` for one that reads back exactly)."""
        lines = [f"name = {_toml_str(self.name)}", f"description = {_toml_str(self.description)}",
                 "tags = [" + ", ".join(_toml_str(t) for t in self.tags) + "]", f"duration = {_num(self.duration)}"]
        if self.variant_of:
            lines.append(f"variant_of = {_toml_str(self.variant_of)}")
        driven = self.driven()
        bones = [b for b in BONE_NAMES if LIMB_OF[b] in driven]
        held = REST_DIRS.copy()
        held_hands = dict(REST_HANDS)
        # a driven limb that never leaves the rest pose is named "rest" in the first keyframe
        still = [limb for limb in driven
                 if all(np.array_equal(k.pose.reshape(N_BONES, 3)[BONE_INDEX[b]], REST_DIRS[BONE_INDEX[b]])
                        for k in self.keys for b in LIMBS[limb])]
        for i, key in enumerate(self.keys):
            lines += ["", "[[keyframes]]", f"time = {_num(key.time)}"]
            if key.label:
                lines.append(f"label = {_toml_str(key.label)}")
            if key.stroke:
                lines.append("stroke = true")
            dirs = key.pose.reshape(N_BONES, 3)
            for b in bones:
                v = dirs[BONE_INDEX[b]]
                rest = REST_DIRS[BONE_INDEX[b]]
                if np.array_equal(v, held[BONE_INDEX[b]]) and not (i == 0 and LIMB_OF[b] in still):
                    continue
                if np.array_equal(v, rest):
                    lines.append(f'{b} = "rest"')
                else:
                    lines.append(f"{b} = [" + ", ".join(repr(float(x)) for x in v) + "]")
                held[BONE_INDEX[b]] = v
            for k in HAND_ORDER:
                if key.hands[k] != held_hands[k]:
                    lines.append(f"{k} = {_toml_str(key.hands[k])}")
                    held_hands[k] = key.hands[k]
        return "\n".join(lines) + "\n"

    def spec(self) -> GestureSpec:
        """The spec the reader makes of :meth:`spec_text`; :class:`DraftError` (one line) when it refuses it."""
        return _parse(self.spec_text(), self.name)

    def canonical(self) -> Draft:
        """This draft as its spec file reads back: every direction the one the reader's
        normalisation keeps, every time to the microsecond, so that writing it and reading it
        back give the same keyframes, and the same text again."""
        keys = [dataclasses.replace(k, time=round(float(k.time), TIME_DECIMALS), pose=_settled(k.pose)) for k in self.keys]
        draft = dataclasses.replace(self, duration=round(float(self.duration), TIME_DECIMALS), keys=keys)
        return Draft.from_spec(_parse(draft.spec_text(), draft.name), drives=draft.drives)

    def mirrored(self) -> Draft:
        """The draft played with ``flip``: left and right swapped (x negated, hands' sides swapped)."""
        keys = [dataclasses.replace(k, pose=mirror_pose(k.pose).astype(np.float64), hands={mirror_name(h): v for h, v in k.hands.items()})
                for k in self.keys]
        return dataclasses.replace(self, keys=keys, drives=frozenset(mirror_name(limb) for limb in self.drives))

    # -- reading ----------------------------------------------------------------------------

    @classmethod
    def from_spec(cls, spec: GestureSpec, drives=None) -> Draft:
        """A draft of a gesture's spec: each keyframe's whole pose and hands as the spec holds
        them there; ``drives`` the limbs it names (default :attr:`GestureSpec.limbs`)."""
        hands = dict(REST_HANDS)
        keys = []
        for k, dirs in zip(spec.keyframes, spec.key_dirs):
            hands = {**hands, **k.hands}
            keys.append(PoseKey(k.time, np.asarray(dirs, np.float64).reshape(-1).copy(), dict(hands), k.label or "", k.stroke))
        return cls(spec.name, spec.duration, keys, spec.description, tuple(spec.tags),
                   frozenset(spec.limbs if drives is None else drives), spec.variant_of)

    def to_dict(self) -> dict:
        """The draft as JSON for a page (the form :meth:`from_dict` reads)."""
        return {"name": self.name, "description": self.description, "tags": list(self.tags), "duration": self.duration,
                "drives": [limb for limb in LIMBS if limb in self.drives], "driven": list(self.driven()),
                "variant_of": self.variant_of,
                "keyframes": [{"time": k.time, "label": k.label, "stroke": k.stroke, "pose": [float(x) for x in k.pose],
                               "hands": {h: k.hands[h] for h in HAND_ORDER}} for k in self.keys]}

    @classmethod
    def from_dict(cls, data) -> Draft:
        """A draft from a page's JSON (untrusted: every field checked; :class:`DraftError`, one line)."""
        if not isinstance(data, dict):
            raise DraftError("a gesture must be a JSON object")
        unknown = sorted(set(data) - {"name", "description", "tags", "duration", "drives", "driven", "variant_of", "keyframes"})
        if unknown:
            raise DraftError(f"unknown field '{unknown[0]}' in the gesture")
        name = data.get("name")
        if not isinstance(name, str) or not NAME_RE.match(name):
            raise DraftError(f"the gesture's name {name!r} must be lower-case letters, digits and '_', starting with a letter")
        description = _text(data.get("description", ""), "description")
        tags = data.get("tags", [])
        if not isinstance(tags, list) or len(tags) > MAX_TAGS:
            raise DraftError(f"tags must be a list of at most {MAX_TAGS} strings")
        tags = tuple(_text(t, "a tag") for t in tags)
        duration = _number(data.get("duration"), "duration")
        if not 0 < duration <= MAX_DURATION:
            raise DraftError(f"duration must be more than 0 and at most {MAX_DURATION:g} seconds, got {duration:g}")
        drives = data.get("drives", [])
        if not isinstance(drives, list) or any(d not in LIMBS for d in drives):
            raise DraftError(f"drives must be a list of limbs ({', '.join(LIMBS)})")
        variant_of = data.get("variant_of")
        if variant_of is not None and (not isinstance(variant_of, str) or not NAME_RE.match(variant_of)):
            raise DraftError("variant_of must name a gesture")
        raw = data.get("keyframes")
        if not isinstance(raw, list) or not 1 <= len(raw) <= MAX_KEYFRAMES:
            raise DraftError(f"keyframes must be a list of 1 to {MAX_KEYFRAMES} keyframes")
        keys = [_key(k, i) for i, k in enumerate(raw)]
        if sum(k.stroke for k in keys) > 1:
            raise DraftError("at most one keyframe is the stroke")
        return cls(name, duration, keys, description, tags, frozenset(drives), variant_of)


def _settled(pose: np.ndarray) -> np.ndarray:
    """``pose`` with every bone a unit vector whose length numpy computes as exactly 1.0 (so the
    spec reader's ``v / norm(v)`` keeps it as it is), the nearest to the bone's direction found by
    moving its components by a few units in the last place; the rest directions as they are."""
    dirs = np.asarray(pose, np.float64).reshape(N_BONES, 3).copy()
    for b in range(N_BONES):
        v = dirs[b]
        if np.array_equal(v, REST_DIRS[b]):
            continue
        v = v / float(np.linalg.norm(v))
        dirs[b] = _exactly_unit(v)
    return dirs.reshape(-1)


def _exactly_unit(v: np.ndarray) -> np.ndarray:
    if float(np.linalg.norm(v)) == 1.0:
        return v
    order = np.argsort(-np.abs(v))  # the largest components move the length most
    steps = sorted(range(-6, 7), key=abs)
    for i, j in ((order[0], order[1]), (order[1], order[2]), (order[0], order[2])):
        for a in steps:
            for b in steps:
                w = v.copy()
                w[i] = _ulps(w[i], a)
                w[j] = _ulps(w[j], b)
                if float(np.linalg.norm(w)) == 1.0:
                    return w
    return v  # never seen: read back, it moves by a unit in the last place


def _ulps(x: float, n: int) -> float:
    for _ in range(abs(n)):
        x = np.nextafter(x, np.inf if n > 0 else -np.inf)
    return float(x)


def _parse(text: str, name: str) -> GestureSpec:
    try:
        return parse_spec_text(text, Path(f"{name}.toml"))
    except SpecError as exc:
        raise DraftError(f"{name}: {exc.field + ': ' if exc.field else ''}{exc.message}") from None


def _text(value, what: str) -> str:
    if not isinstance(value, str) or len(value) > MAX_TEXT:
        raise DraftError(f"{what} must be a string of at most {MAX_TEXT} characters")
    return value


def _number(value, what: str) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise DraftError(f"{what} must be a number, got {value!r}")
    return float(value)


def _key(raw, i: int) -> PoseKey:
    where = f"keyframes[{i}]"
    if not isinstance(raw, dict) or set(raw) - {"time", "label", "stroke", "pose", "hands"}:
        raise DraftError(f"{where} must be an object with time, label, stroke, pose and hands")
    time = _number(raw.get("time"), f"{where}.time")
    label = _text(raw.get("label", "") or "", f"{where}.label")
    stroke = raw.get("stroke", False)
    if not isinstance(stroke, bool):
        raise DraftError(f"{where}.stroke must be true or false")
    pose = raw.get("pose")
    if not isinstance(pose, list) or len(pose) != POSE_DIM:
        raise DraftError(f"{where}.pose must be {POSE_DIM} numbers (the 9 bones' directions)")
    pose = np.array([_number(x, f"{where}.pose") for x in pose], dtype=np.float64)
    if np.any(np.linalg.norm(pose.reshape(N_BONES, 3), axis=1) < 1e-6):
        raise DraftError(f"{where}.pose has a bone of zero length")
    hands = raw.get("hands", REST_HANDS)
    if not isinstance(hands, dict) or set(hands) != set(HAND_ORDER):
        raise DraftError(f"{where}.hands must name {', '.join(HAND_ORDER)}")
    for h, value in hands.items():
        names = SHAPES if h.endswith("_hand") else PALMS
        if value not in names:
            raise DraftError(f"{where}.hands.{h}: {value!r} is not one of {', '.join(names)}")
    return PoseKey(time, pose, dict(hands), label, stroke)


def new_draft(name: str, pose=None, hands=None) -> Draft:
    """A new gesture of three keyframes as the library's have them: the start at rest, the stroke
    (``pose`` and ``hands``, the rest pose by default) and the retraction to rest, in 1.2 s."""
    stroke = rest_pose() if pose is None else np.asarray(pose, np.float64).reshape(-1).copy()
    return Draft(name, 1.2, [PoseKey(0.0, rest_pose(), dict(REST_HANDS), "start"),
                             PoseKey(0.5, stroke, dict(hands or REST_HANDS), "stroke", True),
                             PoseKey(1.2, rest_pose(), dict(REST_HANDS), "retract")])


# -- saving ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Saved:
    """What :func:`save` wrote: where, the text, its SHA-256, and the draft as read back."""

    path: Path
    text: str
    sha256: str
    draft: Draft


def sha256_of(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def save(draft: Draft, folder: Path | str, *, subfolder: str = "", replace: bool = False,
         expected_sha256: str | None = None, elsewhere: str | None = None) -> Saved:
    """Write ``draft`` (made :meth:`canonical`) as ``folder/NAME.toml`` (``folder/SUBFOLDER/NAME.toml``,
    the subfolder made if needed), atomically and inside ``folder`` (no link followed there).

    Refused (:class:`GestureExists`) when the file is there, or when ``elsewhere`` says where
    else a gesture of that name lives (a built-in, another folder the script sees), unless
    ``replace``; a replacement with ``expected_sha256`` is refused (:class:`FileChanged`) when the
    file there is not that one any more. A spec the reader refuses is a :class:`DraftError`;
    the folder's own problems (a link, a file where it goes) :class:`core.fileio.OutputError`."""
    canonical = draft.canonical()
    text = canonical.spec_text()
    data = text.encode("utf-8")
    rel = f"{subfolder}/{canonical.name}.toml" if subfolder else f"{canonical.name}.toml"
    with Inside(folder) as d:
        shown = d.shown(rel)
        old = d.read(rel, LIMITS["gesture spec"])
        if old is not None and not replace:
            raise GestureExists(f"{shown} exists: replace it, or choose another name", sha256_of(old))
        if old is None and elsewhere and not replace:
            raise GestureExists(f"a gesture '{canonical.name}' exists ({elsewhere}): replace it here, or choose another name", None)
        if old is not None and expected_sha256 is not None and sha256_of(old) != expected_sha256:
            raise FileChanged(f"{shown} changed on disk since it was read: open it again, then save")
        try:
            d.write(rel, data, exclusive=old is None)
        except OutputExists:  # made meanwhile
            raise GestureExists(f"{shown} exists: replace it, or choose another name", None) from None
    return Saved(Path(shown), text, sha256_of(data), canonical)


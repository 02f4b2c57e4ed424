"""The control layout: the per-frame arrays the generator consumes (SGToolkit Eq. 1-3).

- pose controls: ``pose`` (T, 27) requested poses, ``pose_mask`` (T,) 1 where a pose is requested;
  ``bone_mask`` (T, 9) 1 on the bones a gesture drives (a one-handed point drives the right arm,
  a nod the head); the other bones of a controlled frame are left to the generator. The
  network's control vector has one pose mask bit per frame, so ``bone_mask`` is not part of
  :data:`CONTROL_LAYOUT`: :func:`network_pose_controls` says what the network is fed, and the
  pose-control blend (``model.postprocess``) applies the per-bone mask;
- style controls: ``style`` (T, 3) values in [-3, 3] for (speed, space, handedness), and
  ``style_mask`` (T, 3) 1 where that style element is requested.

Uncontrolled frames hold zeros. The network reads them as one control vector per frame,
:data:`CONTROL_LAYOUT` (names, widths, order), built by
:func:`control_vector_parts` for numpy arrays and torch tensors alike. This module is the only
place that knows the layout; the compiler fills it, the generator and the metrics read it, and
weights files record it (:mod:`model.weights`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.skeleton import N_BONES, POSE_DIM

#: Style elements, in array order.
STYLE_NAMES: tuple[str, ...] = ("speed", "space", "handedness")
STYLE_INDEX = {name: i for i, name in enumerate(STYLE_NAMES)}
#: Style values are normalised statistics clamped to [-STYLE_LIMIT, STYLE_LIMIT].
STYLE_LIMIT = 3.0

#: The per-frame control vector of the generator, in order: (part, width). Values are masked
#: (uncontrolled values read as 0 whatever the arrays hold), then the masks follow them.
CONTROL_LAYOUT: tuple[tuple[str, int], ...] = (
    ("pose", POSE_DIM),
    ("pose_mask", 1),
    ("style", len(STYLE_NAMES)),
    ("style_mask", len(STYLE_NAMES)),
)
#: Width of the control vector: pose (27) + pose mask (1) + style (3) + style mask (3) = 34.
CONTROL_DIM = sum(width for _, width in CONTROL_LAYOUT)


def control_vector_parts(pose, pose_mask, style, style_mask) -> list:
    """The parts of the control vector in :data:`CONTROL_LAYOUT` order, for numpy arrays or
    torch tensors with any leading axes: pose (..., 27), pose_mask (...), style (..., 3),
    style_mask (..., 3). Concatenated along the last axis they are (..., CONTROL_DIM)."""
    parts = {"pose": pose * pose_mask[..., None], "pose_mask": pose_mask[..., None],
             "style": style * style_mask, "style_mask": style_mask}
    return [parts[name] for name, _ in CONTROL_LAYOUT]


def network_pose_controls(pose: np.ndarray, pose_mask: np.ndarray, bone_mask: np.ndarray | None):
    """The (pose, pose_mask) the network is fed for per-bone controls.

    A frame that controls every bone is fed as it is. A frame that controls only some bones is
    fed as *uncontrolled* (mask 0): the network's single mask bit would otherwise make it
    follow the whole requested pose, holding the bones the gesture leaves free where the
    gesture's spec happens to put them; left free, it moves them with the speech, and the blend
    afterwards puts the controlled bones exactly where they were asked for
    (docs/library.md, *Layered gestures*, has the measurement behind this choice)."""
    pose_mask = np.asarray(pose_mask, np.float32)
    if bone_mask is None:
        return pose, pose_mask
    full = np.asarray(bone_mask).min(axis=-1) > 0.5
    return pose, np.where(full, pose_mask, 0.0).astype(np.float32)


@dataclass
class ControlArrays:
    pose: np.ndarray  # (T, 27) float32
    pose_mask: np.ndarray  # (T,) float32
    style: np.ndarray  # (T, 3) float32
    style_mask: np.ndarray  # (T, 3) float32
    #: (T, 9) float32: 1 on the controlled bones of each frame; None = every bone of every
    #: frame whose ``pose_mask`` is set.
    bone_mask: np.ndarray | None = None

    def bones(self) -> np.ndarray:
        """(T, 9) float32: 1 where a bone of a frame is controlled (and its frame's pose_mask is set)."""
        m = np.asarray(self.pose_mask, np.float32)[:, None]
        if self.bone_mask is None:
            return np.repeat(m, N_BONES, axis=1)
        return np.asarray(self.bone_mask, np.float32) * m

    @property
    def n_frames(self) -> int:
        return int(self.pose.shape[0])

    @classmethod
    def empty(cls, n_frames: int) -> "ControlArrays":
        return cls(
            pose=np.zeros((n_frames, POSE_DIM), np.float32),
            pose_mask=np.zeros((n_frames,), np.float32),
            style=np.zeros((n_frames, len(STYLE_NAMES)), np.float32),
            style_mask=np.zeros((n_frames, len(STYLE_NAMES)), np.float32),
        )

    def set_pose(self, start: int, poses: np.ndarray, bones: np.ndarray | None = None) -> None:
        """Request ``poses`` (L, 27) from frame ``start``; parts outside [0, T) are dropped.

        With ``bones`` (9,) bool only those bones are requested: the others keep what an
        earlier request put there (a nod under a point: both play) or stay free."""
        lo, hi = max(0, start), min(self.n_frames, start + len(poses))
        if hi <= lo:
            return
        src = np.asarray(poses[lo - start : hi - start], np.float32)
        if bones is None or np.all(bones):
            self.pose[lo:hi] = src
            if self.bone_mask is not None:
                self.bone_mask[lo:hi] = 1.0
            self.pose_mask[lo:hi] = 1.0
            return
        if self.bone_mask is None:
            self.bone_mask = np.repeat(self.pose_mask[:, None], N_BONES, axis=1).astype(np.float32)
        cols = np.repeat(np.asarray(bones, bool), 3)
        self.pose[lo:hi, cols] = src[:, cols]
        self.bone_mask[lo:hi, np.asarray(bones, bool)] = 1.0
        self.pose_mask[lo:hi] = 1.0

    def set_style(self, start: int, end: int, values: dict[str, float]) -> None:
        """Request style ``values`` (by name) on frames [start, end)."""
        lo, hi = max(0, start), min(self.n_frames, end)
        for name, value in values.items():
            k = STYLE_INDEX[name]
            self.style[lo:hi, k] = max(-STYLE_LIMIT, min(STYLE_LIMIT, float(value)))
            self.style_mask[lo:hi, k] = 1.0

    def as_dict(self) -> dict[str, np.ndarray]:
        return {
            "pose": self.pose,
            "pose_mask": self.pose_mask,
            "style": self.style,
            "style_mask": self.style_mask,
            "bone_mask": self.bones(),
        }


@dataclass
class Control:
    """One control of an utterance as written in the script, placed on its frames.

    ``kind`` is "pose", "style" or "pause"; frames are [start_frame, end_frame) on the
    utterance's motion; ``line``/``col`` point at the tag in the script (0 when unknown).
    A pose control of a gesture with a stroke also has ``stroke_frame`` (where its stroke
    keyframe plays) and ``word_frame`` (the onset frame of the word it marks, where the stroke
    is meant to land; the end of the previous word when no word follows), on the same frames.
    In files: :meth:`to_dict` / :meth:`from_dict`.
    """

    kind: str
    name: str
    start_frame: int
    end_frame: int  # exclusive
    line: int = 0
    col: int = 0
    options: dict = field(default_factory=dict)
    stroke_frame: int | None = None
    word_frame: int | None = None

    def shifted(self, frames: int) -> "Control":
        return Control(self.kind, self.name, self.start_frame + frames, self.end_frame + frames,
                       self.line, self.col, dict(self.options),
                       None if self.stroke_frame is None else self.stroke_frame + frames,
                       None if self.word_frame is None else self.word_frame + frames)

    def to_dict(self) -> dict:
        d = {
            "kind": self.kind,
            "name": self.name,
            "start_frame": self.start_frame,
            "end_frame": self.end_frame,
            "line": self.line,
            "col": self.col,
            "options": dict(sorted(self.options.items())),  # one order, however they were written or read
        }
        if self.stroke_frame is not None:
            d["stroke_frame"] = self.stroke_frame
        if self.word_frame is not None:
            d["word_frame"] = self.word_frame
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "Control":
        """Raises ValueError on a malformed entry."""
        try:
            options = d.get("options") or {}
            if not isinstance(options, dict):
                raise TypeError("options must be an object")
            stroke, word = d.get("stroke_frame"), d.get("word_frame")
            return cls(str(d["kind"]), str(d["name"]), int(d["start_frame"]), int(d["end_frame"]),
                       int(d.get("line") or 0), int(d.get("col") or 0), dict(options),
                       None if stroke is None else int(stroke), None if word is None else int(word))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise ValueError(f"a control needs kind, name, start_frame and end_frame, got {d!r}") from exc

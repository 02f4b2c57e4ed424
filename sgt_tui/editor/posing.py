"""Posing a gesture with the keys (`sgt edit`'s pose mode, docs/editor.md): the editing model, no Textual.

A :class:`PoseSession` holds a gesture being made (:class:`library.posing.Draft`: keyframes with
whole poses and hands by name), the keyframe shown and the joint selected, and moves that joint in
the **preview's screen axes** (right, up, and nearer the viewer: :func:`renders.terminal.project`
draws the figure turned by :data:`renders.terminal.DEFAULT_YAW`) by the inverse kinematics of
:mod:`core.ik`, the same that ``sgt view``'s page poses with:

- a wrist moves with its arm at the bone lengths (an exact two-bone solve, the elbow kept on its
  side); an elbow turns about the shoulder-wrist line (the wrist stays); a shoulder shrugs or
  pushes forward; the neck leans the torso; the head turns (left/right yaw, up/down pitch,
  nearer/farther roll); ``[`` and ``]`` twist the forearm, turning the palm to the next named one;
- every edit can be undone and redone; keyframes are added, removed, marked the stroke;
- :meth:`PoseSession.save` writes the spec file (:func:`library.posing.save`: atomically, inside
  the gesture folder, never over another gesture without ``replace``, never over a file changed
  since it was opened).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from pathlib import Path

import numpy as np

from core import ik
from core.hands import PALMS, SHAPES
from core.skeleton import JOINT_INDEX, pose_from_positions, positions_from_pose
from library import Gesture
from library.posing import Draft, PoseKey, Saved, joints_of, new_draft, save
from renders.terminal import DEFAULT_YAW, figure_points

#: The joints the keys move, in the order tab goes through them.
JOINTS = ("right_wrist", "right_elbow", "left_wrist", "left_elbow", "head", "neck", "right_shoulder", "left_shoulder")
STEP = 0.02  # metres a key moves a joint
TURN = 5.0  # degrees a key turns the head
TWIST = 45.0  # degrees a key twists the forearm (the palm turns to the nearest named one)
MAX_UNDO = 500


def screen_axes(yaw: float = DEFAULT_YAW) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The preview's right, up and towards-the-viewer directions in the skeleton's coordinates."""
    a = math.radians(yaw)
    return np.array([math.cos(a), 0.0, math.sin(a)]), np.array([0.0, 1.0, 0.0]), np.array([-math.sin(a), 0.0, math.cos(a)])


class PoseSession:
    """A gesture being posed with the keys (the module's docstring)."""

    def __init__(self, draft: Draft | None = None, *, source: Path | None = None, sha256: str | None = None) -> None:
        self.draft = draft if draft is not None else new_draft("my_gesture")
        self.key = next((i for i, k in enumerate(self.draft.keys) if k.stroke), 0)
        self.joint = JOINTS[0]
        self.source, self.sha256 = source, sha256  # the file it was opened from or saved to, as read
        self._undo: list[tuple[Draft, int]] = []
        self._redo: list[tuple[Draft, int]] = []

    @classmethod
    def of_gesture(cls, gesture: Gesture, sha256: str | None) -> PoseSession:
        return cls(Draft.from_spec(gesture.spec).canonical(), source=Path(gesture.path), sha256=sha256)

    # -- what is shown -------------------------------------------------------------------------

    @property
    def current(self) -> PoseKey:
        return self.draft.keys[self.key]

    def side(self) -> str:
        """The side the selected joint is on (the right for the head and the neck)."""
        return "left" if self.joint.startswith("left") else "right"

    def points(self) -> np.ndarray:
        """The keyframe shown as the preview draws it: (1, 50, 3), the joints then the hands' joints."""
        positions, hands = joints_of(self.current.pose, self.current.hands)
        return np.concatenate([positions, hands.reshape(-1, 3)])[None]

    def clip(self) -> tuple[np.ndarray, int | None]:
        """The gesture as the library plays it: its frames as the preview draws them, and its stroke frame."""
        clip = Gesture(self.draft.canonical().spec(), "the editor").clip()
        return figure_points(positions_from_pose(clip.poses), clip.hands), clip.stroke_frame

    def strip(self, width: int = 40) -> str:
        """The keyframes on a line ``width`` wide: ``◆`` each, ``★`` the stroke, the shown one bracketed."""
        cells = [" "] * (width + 2)
        for i, k in enumerate(self.draft.keys):
            at = 1 + round(k.time / self.draft.duration * (width - 1)) if self.draft.duration else 1
            mark = "★" if k.stroke else "◆"
            cells[at] = mark
            if i == self.key:
                cells[at - 1], cells[min(at + 1, width + 1)] = "[", "]"
        return "".join(cells)

    def describe(self) -> str:
        k = self.current
        pose = k.pose
        side = self.side()
        yaw, pitch, roll = ik.head_angles(pose)
        return "\n".join([
            f"{self.draft.name} · {self.draft.duration:g} s · drives {', '.join(self.draft.driven()) or 'nothing yet'}",
            self.strip(),
            f"keyframe {self.key + 1}/{len(self.draft.keys)} at {k.time:.2f} s · {k.label or '-'}" + (" · the stroke" if k.stroke else ""),
            f"joint: {self.joint.replace('_', ' ')} · {side} hand {k.hands[f'{side}_hand']}, palm {k.hands[f'{side}_palm']}",
            (f"elbows: right {ik.elbow_flexion(pose, 'right'):.0f}° (swivel {ik.swivel(pose, 'right'):.0f}°) · "
             f"left {ik.elbow_flexion(pose, 'left'):.0f}° (swivel {ik.swivel(pose, 'left'):.0f}°) · head {yaw:.0f}/{pitch:.0f}/{roll:.0f}°"),
        ])

    # -- edits ---------------------------------------------------------------------------------

    def _edit(self, change) -> bool:
        """``change()`` as one undoable step (nothing recorded when it changed nothing)."""
        before = (copy.deepcopy(self.draft), self.key)
        change()
        if _same(before[0], self.draft) and before[1] == self.key:
            return False
        self._undo.append(before)
        del self._undo[:-MAX_UNDO]
        self._redo.clear()
        return True

    def undo(self) -> bool:
        return self._step(self._undo, self._redo)

    def redo(self) -> bool:
        return self._step(self._redo, self._undo)

    def _step(self, source: list, target: list) -> bool:
        if not source:
            return False
        target.append((copy.deepcopy(self.draft), self.key))
        self.draft, self.key = source.pop()
        return True

    def select(self, step: int) -> None:
        self.joint = JOINTS[(JOINTS.index(self.joint) + step) % len(JOINTS)]

    def move(self, right: float, up: float, near: float) -> bool:
        """Move the selected joint by ``right``, ``up`` and ``near`` key steps in the preview's axes
        (the head turns instead: yaw, pitch, roll)."""
        pose = self.current.pose
        if self.joint == "head":
            yaw, pitch, roll = ik.head_angles(pose)
            return self._set_pose(ik.set_head(pose, yaw + TURN * right, pitch - TURN * up, roll + TURN * near))
        r, u, n = screen_axes()
        delta = STEP * (right * r + up * u + near * n)
        x = positions_from_pose(pose)
        at = lambda joint: x[JOINT_INDEX[joint]]
        side = self.side()
        if self.joint.endswith("_wrist"):
            new = ik.solve_arm(pose, side, at(self.joint) + delta)
        elif self.joint.endswith("_elbow"):
            new = ik.solve_arm(pose, side, at(f"{side}_wrist"), pole=at(self.joint) + delta)
        elif self.joint.endswith("_shoulder"):
            new = ik.set_shoulder(pose, side, at(self.joint) + delta - at("neck"))
        else:  # the neck: the torso leans
            new = ik.set_torso(pose, at("neck") + delta - at("spine"))
        return self._set_pose(new)

    def _set_pose(self, pose: np.ndarray) -> bool:
        def change() -> None:
            self.current.pose = np.asarray(pose, np.float64)

        return self._edit(change)

    def twist(self, step: int) -> bool:
        """Twist the forearm of the selected side: its palm turns to the named palm it reaches."""
        side = self.side()
        key = f"{side}_palm"
        palm = ik.twist_palm(self.current.pose, side, self.current.hands[key], TWIST * step)
        return self._edit(lambda: self.current.hands.__setitem__(key, palm))

    def cycle_hand(self, what: str, step: int = 1) -> bool:
        """The selected side's next hand shape (``what="hand"``) or palm (``"palm"``)."""
        names = SHAPES if what == "hand" else PALMS
        key = f"{self.side()}_{what}"
        value = names[(names.index(self.current.hands[key]) + step) % len(names)]
        return self._edit(lambda: self.current.hands.__setitem__(key, value))

    def goto(self, step: int) -> None:
        self.key = min(max(0, self.key + step), len(self.draft.keys) - 1)

    def add_key(self) -> bool:
        """A keyframe after the one shown, half way to the next (after the last: 0.3 s later, the
        gesture made longer), with its pose and hands."""
        keys = self.draft.keys
        here = keys[self.key]
        if self.key + 1 < len(keys):
            time = round((here.time + keys[self.key + 1].time) / 2, 3)
        else:
            time = round(here.time + 0.3, 3)
        stroke_at = next((i for i, k in enumerate(keys) if k.stroke), None)
        label = "retract" if self.key + 1 == len(keys) else ("hold" if stroke_at is not None and stroke_at <= self.key else "prepare")

        def change() -> None:
            self.draft.keys.insert(self.key + 1, PoseKey(time, here.pose.copy(), dict(here.hands), label))
            self.draft.duration = max(self.draft.duration, time)
            self.key += 1

        return self._edit(change)

    def remove_key(self) -> bool:
        if len(self.draft.keys) <= 1:
            return False

        def change() -> None:
            del self.draft.keys[self.key]
            self.key = min(self.key, len(self.draft.keys) - 1)

        return self._edit(change)

    def toggle_stroke(self) -> bool:
        def change() -> None:
            on = not self.current.stroke
            for i, k in enumerate(self.draft.keys):
                k.stroke = on and i == self.key
            if on and not self.current.label:
                self.current.label = "stroke"

        return self._edit(change)

    def mirror(self) -> bool:
        def change() -> None:
            self.draft = self.draft.mirrored()

        return self._edit(change)

    def set_label(self, label: str) -> bool:
        """The keyframe shown's label (at most 100 characters)."""
        return self._edit(lambda: setattr(self.current, "label", label.strip()[:100]))

    def rename(self, name: str) -> bool:
        return self._edit(lambda: setattr(self, "draft", dataclasses.replace(self.draft, name=name)))

    def from_positions(self, positions: np.ndarray, hands: dict[str, str] | None = None) -> bool:
        """The keyframe shown takes the pose of joint positions (10, 3) (a frame of the preview)."""
        pose = pose_from_positions(np.asarray(positions, np.float64)[:10]).astype(np.float64)

        def change() -> None:
            self.current.pose = pose
            if hands:
                self.current.hands = dict(hands)

        return self._edit(change)

    # -- saving --------------------------------------------------------------------------------

    def save(self, folder: Path, *, replace: bool = False, elsewhere: str | None = None) -> Saved:
        """Write the gesture into ``folder`` (:func:`library.posing.save`); a replacement of the
        file it was opened from or last saved to is refused when that file changed since."""
        target = Path(folder) / f"{self.draft.name}.toml"
        same = self.source is not None and _same_path(self.source, target)
        saved = save(self.draft, folder, replace=replace, expected_sha256=self.sha256 if same else None, elsewhere=elsewhere)
        self.draft = saved.draft
        self.source, self.sha256 = target, saved.sha256
        return saved


def _same(a: Draft, b: Draft) -> bool:
    return a.to_dict() == b.to_dict()


def _same_path(a: Path, b: Path) -> bool:
    try:
        return Path(a).resolve() == Path(b).resolve()
    except OSError:
        return False

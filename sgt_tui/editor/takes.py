"""What the preview and the timeline show for an utterance: its generated motion, else a draft.

Generated motion is kept per utterance *key* (its text and the header: see
:class:`sgt_tui.editor.analysis.UtteranceInfo`), so it is shown for as long as that text is
unchanged; otherwise the preview shows a draft, the keyframe engine through the pose controls
with estimated timing (computed on the spot and cached). :meth:`Takes.view` returns a
:class:`View` the widgets draw as it is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.counting import number
from core.motion import MotionClip
from core.skeleton import positions_from_pose
from model import keyframe
from model.generate import EngineInputs
from model.hands import motion_hands
from renders.terminal import figure_points
from sgt_tui.editor.timeline import TimelineData, from_clip, from_plan

KEEP = 256  # generated takes and drafts kept


@dataclass(frozen=True)
class View:
    positions: np.ndarray | None  # (T, 10 or 50, 3) for the preview (renders.terminal.figure_points), None: nothing to play
    label: str  # under the preview: "generated · rules", "draft · ^g generates"
    timeline: TimelineData | None
    title: str  # the timeline's title
    no_timeline: str = ""  # what the timeline says when there is nothing to show
    no_motion: str = ""  # what the preview says when there is nothing to play
    generated: bool = False


class Takes:
    def __init__(self) -> None:
        self.generated: dict[str, tuple[str, MotionClip]] = {}  # utterance key -> (engine, clip)
        self._drafts: dict[str, np.ndarray] = {}

    def add(self, key: str, engine: str, clip: MotionClip) -> None:
        self.generated.pop(key, None)
        self.generated[key] = (engine, clip)
        while len(self.generated) > KEEP:
            del self.generated[next(iter(self.generated))]

    def has(self, key: str | None) -> bool:
        return key in self.generated

    def view(self, info) -> View:
        """What to show for an :class:`~sgt_tui.editor.analysis.UtteranceInfo` (None: no utterance)."""
        if info is None:
            return View(None, "", None, "timeline", "no utterance yet: type one, e.g.  guide: Hello! [pose:wave]",
                        "write an utterance to see it move")
        title = f"utterance {number(info.index)} (line {info.line})"
        found = self.generated.get(info.key)
        if found is not None:
            engine, clip = found
            data = from_clip(clip, timing="speech")
            return View(figure_points(clip.positions, clip.hands), f"generated · {engine}", data,
                        f"{title} · {data.duration:.1f} s · speech timing", generated=True)
        if info.plan is not None:
            data = from_plan(info.plan)
            return View(self._draft(info), "draft · ^g generates", data,
                        f"{title} · {data.duration:.1f} s · estimated timing")
        return View(None, "", None, title, f"utterance {number(info.index)} has errors: fix them to see its timeline",
                    "fix errors to preview")

    def _draft(self, info) -> np.ndarray:
        hit = self._drafts.get(info.key)
        if hit is None:
            poses = keyframe.generate(EngineInputs.from_plan(info.plan))
            hit = figure_points(positions_from_pose(poses), motion_hands(poses, [info.plan.hands]))
            if len(self._drafts) >= KEEP:
                self._drafts.clear()
            self._drafts[info.key] = hit
        return hit

"""The compiled plan: per utterance its words, controls and the per-frame control arrays.

``plan.json`` is deterministic and human-readable (reviewable in a diff); ``--npz`` holds the
arrays the generator consumes (layout owned by :mod:`core.controls`). Both are written by
:mod:`core.fileio`'s rules (atomically for a regular file; a device or a link is never replaced).
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from core.controls import STYLE_NAMES, Control, ControlArrays
from core.fileio import atomic_write
from core.words import TimedWord

PLAN_FORMAT = "sgt-plan"
PLAN_VERSION = 1


@dataclass
class ArrayRequests:
    """What the control arrays must hold; they are built on first use (``sgt check`` never needs them)."""

    n_frames: int
    poses: list = field(default_factory=list)  # (start frame, library Gesture, PoseMark, frames played)
    styles: list = field(default_factory=list)  # (start, end, {name: value}), outer spans first

    def build(self) -> ControlArrays:
        arrays = ControlArrays.empty(self.n_frames)
        for a, b, values in self.styles:
            arrays.set_style(a, b, values)
        for start, gesture, mark, length in self.poses:  # length < the clip's: its retraction was cut
            arrays.set_pose(start, gesture.clip(speed=mark.speed, flip=mark.flip, hold=mark.hold).poses[:length])
        return arrays


@dataclass
class UtterancePlan:
    index: int
    speaker: str | None
    line: int
    text: str
    duration: float
    n_frames: int
    words: list[TimedWord]
    controls: list[Control]
    requests: ArrayRequests
    speech: dict = field(default_factory=dict)
    audio_path: Path | None = None
    lead_in: float = 0.0  # seconds of silence before the audio starts (words are already shifted)

    _arrays: ControlArrays | None = field(default=None, repr=False)

    @property
    def arrays(self) -> ControlArrays:
        """Per-frame control arrays (SGToolkit Eq. 1-3), layout from :mod:`core.controls`."""
        if self._arrays is None:
            self._arrays = self.requests.build()
        return self._arrays

    def to_dict(self) -> dict:
        return {
            "index": self.index,
            "speaker": self.speaker,
            "line": self.line,
            "text": self.text,
            "duration": round(self.duration, 3),
            "frames": self.n_frames,
            "speech": self.speech,
            "words": [w.to_dict() for w in self.words],
            "controls": [c.to_dict() for c in self.controls],
        }


@dataclass
class Plan:
    source: str
    fps: int
    seed: int
    utterances: list[UtterancePlan]

    def to_dict(self) -> dict:
        return {
            "format": PLAN_FORMAT,
            "version": PLAN_VERSION,
            "source": self.source,
            "fps": self.fps,
            "seed": self.seed,
            "style_names": list(STYLE_NAMES),
            "utterances": [u.to_dict() for u in self.utterances],
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, ensure_ascii=False) + "\n"

    def save_json(self, path) -> None:
        """Write :meth:`to_json` to ``path`` (or a binary stream) by :mod:`core.fileio`'s rules."""
        atomic_write(path, self.to_json().encode("utf-8"))

    def save_npz(self, path) -> None:
        """Arrays ``pose_I``, ``pose_mask_I``, ``style_I``, ``style_mask_I`` per utterance I, plus ``plan`` (JSON);
        to ``path`` (or a binary stream) by :mod:`core.fileio`'s rules."""
        arrays: dict[str, np.ndarray] = {"plan": np.array(self.to_json())}
        for i, u in enumerate(self.utterances):
            for key, value in u.arrays.as_dict().items():
                arrays[f"{key}_{i}"] = value
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        atomic_write(path, buf.getvalue())

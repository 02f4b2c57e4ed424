"""Preview playback: which frame of which motion is shown, and whether it is playing.

The widget owns the timer and calls :meth:`Player.tick` at :data:`core.skeleton.FPS` only
while playing and visible; this object just counts frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.skeleton import FPS


@dataclass
class Player:
    positions: np.ndarray | None = None  # (T, 10, 3), or (T, 50, 3) with the hands (renders.terminal.figure_points)
    frame: int = 0
    playing: bool = False
    label: str = ""  # what is shown: "generated · rules", "draft", a gesture ...

    interval = 1.0 / FPS

    @property
    def n_frames(self) -> int:
        return 0 if self.positions is None else int(len(self.positions))

    @property
    def seconds(self) -> float:
        return self.frame / FPS

    def load(self, positions: np.ndarray | None, label: str = "", *, keep_frame: bool = True) -> None:
        self.positions = None if positions is None or len(positions) == 0 else np.asarray(positions)
        self.label = label
        if not keep_frame:
            self.frame = 0
        self.frame = min(self.frame, max(0, self.n_frames - 1))

    def current(self) -> np.ndarray | None:
        return None if self.positions is None else self.positions[self.frame]

    def tick(self) -> None:
        """Advance one frame, looping at the end."""
        if self.n_frames:
            self.frame = (self.frame + 1) % self.n_frames

    def seek(self, frame: int) -> None:
        self.frame = min(max(0, int(frame)), max(0, self.n_frames - 1))

    def step(self, frames: int) -> None:
        self.seek(self.frame + frames)

    def toggle(self) -> bool:
        self.playing = not self.playing and self.n_frames > 0
        return self.playing

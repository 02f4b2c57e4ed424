"""The flow engine as a stream: frames decided with the network stream's lookahead.

The offline engine (:mod:`model.flow`) samples 4 s windows, each continuing the last
:data:`~model.neural.SEED` frames of the one before. The stream does the same one frame at a
time: to decide frame ``a`` it samples the window of frames ``[a - CONTEXT, a + 1 + LOOKAHEAD)``
with the frames it has already returned (before the filter: what it decided) as whole-pose seed
controls, which the sampler keeps exactly, and keeps the sample's frame ``a``. So each frame
continues the motion decided so far, and a frame is decided once the speech is known
:data:`~model.streaming.LOOKAHEAD_S` (0.467 s) past it, the network stream's lookahead. Each
call draws its noise, (:data:`WINDOW_FRAMES`, 27) numbers, from the seed's random stream, so
a seed is one take however the words arrive.

After the sampler, what every stream shares (:class:`~model.streaming.StreamBase`): the causal
1-euro filter and the pause hold. The speed correction (``follow_speed``) needs 0.7 s of
look-ahead and is not applied; a ``speed`` request is met by the network's style input alone.
One frame costs one sampler call on at most :data:`WINDOW_FRAMES` frames (onnxruntime: a few
milliseconds with the shipped steps, under the 67 ms a frame lasts).
"""

from __future__ import annotations

import numpy as np

from core.skeleton import POSE_DIM
from model.features import word_features
from model.neural import SEED
from model.streaming import LOOKAHEAD, STEP, StreamBase

#: Frames decided before the one being decided that the sampler continues (1 s, the offline seed).
CONTEXT = SEED
#: Frames of one sampler call: the context, the decided frame and the lookahead.
WINDOW_FRAMES = CONTEXT + STEP + LOOKAHEAD


class FlowStreamGenerator(StreamBase):
    """The flow engine's stream over a runner of flow weights (:func:`model.flow.load`). Feed
    timed words (:meth:`add_words`), audio (:meth:`add_audio`), say how far the speech is known
    (:meth:`known_until`); each call returns the frames it could decide, (n, 27) poses;
    :meth:`finish` returns the rest."""

    def __init__(self, runner, *, seed: int = 0, style: dict[str, float] | None = None, smoothing: bool = True) -> None:
        super().__init__(style=style, smoothing=smoothing)
        self.runner = runner
        self.rng = np.random.default_rng(seed)
        self.decided = np.zeros((0, POSE_DIM), np.float32)  # the last CONTEXT frames decided (before the filter)

    def _step(self, limit: int, final: bool = False) -> np.ndarray:
        """Sample the next frame (the seed's noise, the frames decided before it as seed poses)."""
        a = self.done
        s = max(0, a - CONTEXT)
        e = min(a + STEP + LOOKAHEAD, max(limit, a + 1))
        n = e - s
        ids, onsets = word_features(self._recent_words(s), n)
        pose = np.zeros((n, POSE_DIM), np.float32)
        mask = np.zeros(n, np.float32)
        if a > s:
            pose[: a - s] = self.decided[-(a - s):]
        mask[: a - s] = 1.0
        z = self.rng.standard_normal((WINDOW_FRAMES, POSE_DIM)).astype(np.float32)[:n]
        y = self.runner.run_window(self._audio_features(s, e), ids, onsets, pose, mask,
                                   np.repeat(self.style[None], n, 0), np.repeat(self.style_mask[None], n, 0), z)
        frame = y[a - s : a - s + 1]
        self.decided = np.concatenate([self.decided, frame])[-CONTEXT:]
        self.done += 1
        self.spans.append(self._pause_span(a, final))  # the pause hold of _calm_pauses reads it when returned
        return frame

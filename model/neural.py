"""The ``neural`` engine: the controllable generator run over any length of speech.

Long speech is generated in overlapping windows (SGToolkit appendix A.1): windows of
``WINDOW`` frames advance by ``HOP``; the last ``WINDOW - HOP`` generated frames of a window
are fed to the next one as pose controls (seed poses), and the overlap is cross-faded from
the old window to the new one, so joins are continuous. Only one
window is in flight, so memory does not grow with the speech beyond the output itself.

Post-processing (:mod:`model.postprocess`) is switchable through :class:`Options`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from model.features import audio_features, load_audio, word_features

NAME = "neural"
WINDOW = 60
HOP = 30


@dataclass(frozen=True)
class Options:
    smoothing: str = "one_euro"  # "one_euro", "moving_average" or "none"
    blend: bool = True  # exact pose-control blend
    ramp: int = 6  # frames of easing into and out of a controlled span
    weights: str | None = None  # path; None = the shipped weights


@lru_cache(maxsize=4)
def _model(weights: str | None):
    from model.weights import load_weights

    return load_weights(weights)[0]


def speech_inputs(inputs, n_frames: int):
    """(audio features, word ids, onsets) for an EngineInputs on the motion timeline."""
    from model.features import AUDIO_DIM, FPS

    if inputs.audio_path is not None and Path(inputs.audio_path).exists():
        audio = audio_features(load_audio(inputs.audio_path), n_frames, offset_frames=int(round(inputs.lead_in * FPS)))
    else:
        audio = np.zeros((n_frames, AUDIO_DIM), np.float32)
    ids, onsets = word_features(inputs.words, n_frames)
    return audio, ids, onsets


def run_windows(model, audio, ids, onsets, arrays, seed: int) -> np.ndarray:
    """Sliding-window generation: (T, 27) raw network output."""
    import torch

    t_count = arrays.n_frames
    out = np.zeros((t_count, 27), np.float32)
    rng = np.random.default_rng(seed)
    noise_dim = model.config["noise_dim"]
    overlap = WINDOW - HOP
    start = 0
    with torch.inference_mode():
        while True:
            end = min(start + WINDOW, t_count)
            pose = arrays.pose[start:end].copy()
            mask = arrays.pose_mask[start:end].copy()
            if start > 0:  # seed poses from the previous window where the user asked for nothing
                k = min(overlap, end - start)
                free = mask[:k] < 0.5
                pose[:k][free] = out[start : start + k][free]
                mask[:k][free] = 1.0
            z = rng.standard_normal(noise_dim).astype(np.float32)

            def tens(a, dtype=torch.float32):
                return torch.as_tensor(np.ascontiguousarray(a), dtype=dtype)[None]

            y = model(tens(audio[start:end]), tens(ids[start:end], torch.long), tens(onsets[start:end]), tens(pose),
                      tens(mask), tens(arrays.style[start:end]), tens(arrays.style_mask[start:end]), tens(z)[0][None])
            y = y[0].numpy()
            if start > 0:  # cross-fade over the seed frames so the join is continuous
                k = min(overlap, end - start)
                w = ((np.arange(k) + 1) / (k + 1))[:, None].astype(np.float32)
                y[:k] = (1 - w) * out[start : start + k] + w * y[:k]
            out[start:end] = y
            if end >= t_count:
                break
            start += HOP
    return out


def generate(inputs, *, seed: int = 0, options: Options | None = None) -> np.ndarray:
    """Poses (T, 27) for one utterance (an :class:`~model.generate.EngineInputs`)."""
    from model import postprocess

    opts = options or Options()
    model = _model(opts.weights)
    n = inputs.n_frames
    audio, ids, onsets = speech_inputs(inputs, n)
    raw = run_windows(model, audio, ids, onsets, inputs.arrays, seed)
    if opts.smoothing == "one_euro":
        raw = postprocess.one_euro(raw)
    elif opts.smoothing == "moving_average":
        raw = postprocess.moving_average(raw)
    elif opts.smoothing != "none":
        raise ValueError(f"unknown smoothing '{opts.smoothing}'")
    if opts.blend:
        raw = postprocess.blend_pose_controls(raw, inputs.arrays.pose, inputs.arrays.pose_mask, opts.ramp)
    return raw.astype(np.float32)

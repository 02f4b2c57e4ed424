"""Measuring the training takes' postures and drifts that weights carry (:mod:`model.take_posture`).

For each training clip (a random subset of :data:`~model.take_posture.MAX_TAKES` when there are
more), with the network's raw output on the clip's own speech with no controls: the posture is
the mean of its reference poses minus the mean of that output; the drift is the reference minus
the output, both low-passed (Gaussian, :data:`~model.take_posture.DRIFT_SIGMA` frames), less the
posture, each bone's offset shortened to at most :data:`~model.take_posture.DRIFT_LIMIT`, sampled
every :data:`~model.take_posture.DRIFT_STEP` frames. Both are what the network
leaves out of the take, so they depend on the weights: ``sgt train`` measures them at the end
of training for the weights it keeps.
"""

from __future__ import annotations

import numpy as np

from core.controls import ControlArrays
from model import take_posture
from model.postprocess import gauss_smooth


def measure_takes(model, clips, *, seed: int = 0, progress=None) -> take_posture.Takes:
    """The :class:`~model.take_posture.Takes` of ``clips`` for ``model`` (a runner or a GestureNet)."""
    from model.neural import run_windows  # lazy: the engine

    chosen = list(range(len(clips)))
    if len(chosen) > take_posture.MAX_TAKES:
        chosen = sorted(np.random.default_rng(seed).choice(len(clips), take_posture.MAX_TAKES, replace=False).tolist())
    postures, drifts = [], []
    limit = take_posture.POSTURE_LIMIT
    for n, i in enumerate(chosen):
        if progress:
            progress(n, len(chosen), "")
        clip = clips[i]
        raw = run_windows(model, clip["audio"], clip["word_ids"], clip["onsets"], ControlArrays.empty(len(clip["poses"])), seed + i)
        ref = np.asarray(clip["poses"], np.float64)
        posture = ref.mean(axis=0) - raw.astype(np.float64).mean(axis=0)
        postures.append(posture)
        sigma = take_posture.DRIFT_SIGMA  # both low-passed, the edges held
        slow = gauss_smooth(ref, sigma) - gauss_smooth(raw.astype(np.float64), sigma) - posture
        drifts.append(take_posture.limit_bones(slow[:: take_posture.DRIFT_STEP]).astype(np.float32))
    if progress:
        progress(len(chosen), len(chosen), "")
    return take_posture.Takes(np.clip(np.asarray(postures, np.float32).reshape(-1, 27), -limit, limit), tuple(drifts))


def record_takes(weights, clips, *, progress=None) -> take_posture.Takes:
    """Measure ``clips``' takes with the network of the weights file ``weights`` and record them in it."""
    from model.weights import load_weights, set_takes  # lazy: torch

    takes = measure_takes(load_weights(weights)[0], clips, progress=progress)
    set_takes(weights, takes)
    return takes

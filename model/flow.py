"""The ``flow`` engine: the flow-matching sampler of :mod:`model.flow_net` run over any length of speech.

Where the ``neural`` engine's regressor averages the takes its teacher could make, this engine
samples one: each window of :data:`WINDOW` frames starts from Gaussian noise drawn from the
seed (a seed is one take) and flows to poses in the few steps its weights were trained for.

Long speech goes in windows that continue each other (SGToolkit appendix A.1): a window's seed
poses are :data:`SEED` frames the window before made, fed to the network as pose controls,
which it keeps exactly (:meth:`model.flow_net.FlowNet.predict` puts controlled frames in), and
the output switches windows right after the seed. Two things keep the switch from showing: the
seed ends :data:`EDGE` frames before the window before ends (a window's last frames, sampled with
no speech after them, move faster than the rest; the next window samples them again), and the
new window's first free frame continues the seed at its velocity, the difference easing out over
:data:`JOIN` frames (:func:`join`). Unlike :func:`model.neural.run_windows` there is no
cross-fade: two samples of the same speech differ (that is the point of sampling), and a fade
between them would average their strokes away over half of every hop.

The sampled strokes are then re-timed onto the speech as the matching engine re-times its
takes (:func:`beats_on_speech`: each stroke end within 4 frames of an accent or a syllable
onset moves onto it, :func:`model.matching.snap_beats`; no bone faster than the teacher's limit
after it), and the neural engine's post-processing follows (:func:`model.postprocess.finish`):
the zero-phase 1-euro filter, ``follow_speed``, the pause hold and the exact pose-control blend.
The flow draws no training take's posture (:mod:`model.take_posture`): its samples carry their
own holds.
"""

from __future__ import annotations

import numpy as np

from core.controls import network_pose_controls
from core.skeleton import POSE_DIM, normalize_pose
from model import matching, postprocess
from model.features import speech_inputs
from model.neural import SEED, WINDOW, Options, use_threads
from model.runtime import as_runner, load_runner

#: A window's last frames that the next window samples again (its seed ends before them).
EDGE = 5
#: Frames each window adds: windows start this far apart.
HOP = WINDOW - SEED - EDGE
#: Frames over which a window's first free frame eases from continuing the window before (:func:`join`).
JOIN = 10


def load(weights: str | None = None):
    """The flow network's runner for a weights file (None: the shipped ``model/weights/flow.pt``);
    raises :class:`~model.weights.WeightsError` for a missing file or one of another kind."""
    return load_runner(weights, "flow")


def run_windows(model, audio, ids, onsets, arrays, seed: int) -> np.ndarray:
    """Sliding-window sampling: (T, 27) poses before post-processing. ``model`` is a runner of
    :mod:`model.runtime` or a :class:`model.flow_net.FlowNet`; each window's noise is the next
    (WINDOW, 27) normal numbers of the seed's random stream (fewer frames use its first rows)."""
    runner = as_runner(model)
    t_count = arrays.n_frames
    out = np.zeros((t_count, POSE_DIM), np.float32)
    rng = np.random.default_rng(seed)
    start = 0
    while True:
        end = min(start + WINDOW, t_count)
        pose = arrays.pose[start:end].copy()
        mask = network_pose_controls(pose, arrays.pose_mask[start:end], None if arrays.bone_mask is None
                                     else arrays.bone_mask[start:end])[1].copy()
        k = 0
        if start > 0:  # seed poses from the previous window where the user asked for nothing
            k = min(SEED, end - start)
            free = mask[:k] < 0.5
            pose[:k][free] = out[start : start + k][free]
            mask[:k][free] = 1.0
        z = rng.standard_normal((WINDOW, runner.noise_dim)).astype(np.float32)[: end - start]
        y = runner.run_window(audio[start:end], ids[start:end], onsets[start:end], pose, mask, arrays.style[start:end],
                              arrays.style_mask[start:end], z)
        if start > 0:
            y = join(out[start + k - 2 : start + k], y, k, mask)
        out[start + k : end] = y[k:]
        if end >= t_count:
            break
        start += HOP
    return out


def join(before: np.ndarray, y: np.ndarray, k: int, mask: np.ndarray) -> np.ndarray:
    """A window's poses ``y`` whose first free frame ``y[k]`` continues the two frames
    ``before`` it at their velocity: the offset between that continuation and the sample decays
    to nothing over :data:`JOIN` frames (a raised cosine; inertialisation), on the frames the
    user left free, bone directions kept unit. The sampler keeps the seed poses exactly but its
    next frame starts a fresh take: without this the step into it was 3.5 times the median step
    of the shipped weights' windows, with it the largest step of a window's phase is 1.4 times
    (its first free frames move faster than the rest; tests/test_flow_shipped.py)."""
    if k < 1 or k >= len(y) or len(before) < 2:
        return y
    offset = 2 * before[-1] - before[-2] - y[k]
    n = min(JOIN, len(y) - k)
    fade = 0.5 * (1.0 + np.cos(np.pi * np.arange(n) / JOIN)) * (1.0 - mask[k : k + n])
    y = y.copy()
    y[k : k + n] = normalize_pose(y[k : k + n] + fade[:, None] * offset)
    return y


def beats_on_speech(poses: np.ndarray, audio, ids, onsets) -> np.ndarray:
    """``poses`` with their stroke ends moved onto the speech's accents and syllable onsets
    (:func:`model.matching.snap_beats`, the matching engine's targets), then no bone turning
    faster than :data:`model.postprocess.MAX_STEP_DEG` a frame."""
    accents = matching.accents(np.asarray(audio, np.float32)[:, -1], ids, onsets)
    targets = np.union1d(np.flatnonzero(accents >= matching.ACCENT_MIN), matching.syllable_onsets(audio))
    return postprocess.limit_velocity(matching.snap_beats(poses, targets), postprocess.MAX_STEP_DEG).astype(np.float32)


def motion(model, audio, ids, onsets, arrays, seed: int) -> np.ndarray:
    """The engine's motion before post-processing: :func:`run_windows`, then :func:`beats_on_speech`."""
    return beats_on_speech(run_windows(model, audio, ids, onsets, arrays, seed), audio, ids, onsets)


def generate(inputs, *, seed: int = 0, options: Options | None = None) -> np.ndarray:
    """Poses (T, 27) for one utterance (an :class:`~model.generate.EngineInputs`). ``options``
    are the neural engine's (:class:`model.neural.Options`; ``weights``: a flow weights file;
    ``take_posture`` does not apply)."""
    opts = options or Options()
    runner = load(opts.weights)
    use_threads(opts.threads)
    n = inputs.n_frames
    audio, ids, onsets = speech_inputs(inputs, n)
    arrays = inputs.arrays
    raw = motion(runner, audio, ids, onsets, arrays, seed)
    return postprocess.finish(raw, arrays.pose, arrays.pose_mask, smoothing=opts.smoothing,
                              blend=opts.blend, ramp=opts.ramp, bones=arrays.bone_mask, words=inputs.words,
                              style=arrays.style, style_mask=arrays.style_mask)

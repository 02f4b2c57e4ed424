"""The shipped weights (model/weights/generator.pt): they load, fit this code's data layout, and
behave on the shipped example: pose controls followed by the network itself, exactly after the
blend, motion that moves, the same take for the same seed."""

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

from core.controls import network_pose_controls  # noqa: E402
from core.skeleton import REST_POSE  # noqa: E402
from dsl.compiler import compile_file  # noqa: E402
from model import neural  # noqa: E402
from model.generate import EngineInputs  # noqa: E402
from model.training.metrics import group_statistics, pcs  # noqa: E402
from model.weights import DEFAULT_WEIGHTS, load_weights  # noqa: E402

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "mall_guide.sgt"


@pytest.fixture(scope="module")
def utterances():
    result = compile_file(EXAMPLE)
    assert result.plan is not None
    return [EngineInputs.from_plan(u) for u in result.plan.utterances]


def test_shipped_weights_load_with_their_card():
    model, info = load_weights(DEFAULT_WEIGHTS)
    assert sum(p.numel() for p in model.parameters()) > 100_000
    meta = info["meta"]
    assert meta["epochs_done"] >= 1 and "val_pcs" in meta["validation"]


def test_shipped_model_follows_pose_controls_and_moves(utterances):
    raw_opts = neural.Options(smoothing="none", blend=False)
    controlled = 0
    for inputs in utterances:
        a = inputs.arrays
        raw = neural.generate(inputs, seed=0, options=raw_opts)
        out = neural.generate(inputs, seed=0)
        assert out.shape == (inputs.n_frames, 27) and np.isfinite(out).all()
        assert np.allclose(np.linalg.norm(out.reshape(-1, 9, 3), axis=-1), 1, atol=1e-4)
        assert np.array_equal(out, neural.generate(inputs, seed=0))
        assert group_statistics([out], "wrists").speed > 0.05  # m/s: it gestures, it is not a statue
        if a.pose_mask.sum() == 0:
            continue
        controlled += 1
        # layered gestures: the blended output is exact on the controlled bones (PCS 0 there)
        bones = np.repeat(a.bones() > 0.5, 3, axis=1)
        assert np.abs(a.pose[bones] - out[bones]).mean() < 1e-6
        # the network itself follows the frames it is fed as controlled (whole-pose requests)
        fed = network_pose_controls(a.pose, a.pose_mask, a.bone_mask)[1]
        if fed.sum() == 0:
            continue
        still = np.repeat(np.asarray(REST_POSE, np.float32)[None], inputs.n_frames, axis=0)
        assert pcs(a.pose, raw, fed) < 0.5 * pcs(a.pose, still, fed)
        assert pcs(a.pose, raw, fed) < 0.05
    assert controlled >= 3


def test_shipped_model_reads_style_controls_per_frame(utterances):
    """A style span on half of an utterance speeds up that half (the engine does not average
    the per-frame style over the utterance). Measured as the speed style (normalised): the
    unrequested half moves at its drawn take's own pace (its drift), so the raw speed of that
    half depends on the take; a request averaged over the line would leave the two halves
    within 0.1 of each other (+1.25 each)."""
    from core.controls import ControlArrays
    from model.style import style

    inputs = utterances[2]
    n = inputs.n_frames

    def half_change(lo, hi, seed):
        arrays = ControlArrays.empty(n)
        arrays.set_style(lo, hi, {"speed": 2.5})
        speed = style(neural.generate(EngineInputs(arrays, inputs.words, inputs.audio_path, inputs.lead_in), seed=seed))[:, 0]
        return speed[n // 2:].mean() - speed[: n // 2].mean()

    for seed in range(2):
        assert half_change(n // 2, n, seed) > 1.0 and half_change(0, n // 2, seed) < -1.0


@pytest.mark.parametrize("value", [-1.0, 1.0, 2.0])
def test_shipped_engine_meets_a_requested_speed(utterances, value):
    """`<speed:V>` over a whole utterance: the measured speed style (SGToolkit Eq. 4) while
    speaking is V within 0.35 (the network alone gave +0.17 for +1 and +1.26 for +2)."""
    from core.controls import ControlArrays
    from core.skeleton import FPS
    from model.style import style

    inputs = utterances[0]
    n = inputs.n_frames
    arrays = ControlArrays.empty(n)
    arrays.set_style(0, n, {"speed": value})
    speaking = np.zeros(n, bool)
    for w in inputs.words:
        speaking[int(w.start * FPS) : int(np.ceil(w.end * FPS))] = True
    got = [style(neural.generate(EngineInputs(arrays, inputs.words, inputs.audio_path, inputs.lead_in), seed=seed))[speaking, 0].mean()
           for seed in range(2)]
    assert all(abs(g - value) < 0.35 for g in got), got


PAUSES = ("guide: Welcome to the mall. The shops on this floor open at nine every morning, [pause 2s] and the food "
          "court upstairs stays open late. [pause 4s] If you need anything at all, just ask me and I will show you the way.\n")


def test_shipped_model_rests_in_pauses(tmp_path):
    """Issue 10: inside `[pause]` spans (digital silence) the wrists move no faster than while
    speaking (median, mean and peak), and the middle of a long gap is calm. (The weights
    trained on per-utterance z-scored features gestured hardest there: 0.45 m/s inside a
    `[pause 2s]`, 0.15 speaking; the shipped ones, like their teacher, move their arms to rest
    and back in a long pause, up to 0.9 m/s: the engine holds the pose the speaker paused in,
    model/postprocess.py calm_pauses, and without it the mean and peak checks fail.)"""
    from core.skeleton import FPS, JOINTS
    from model.training.metrics import joint_speeds

    script = tmp_path / "pauses.sgt"
    script.write_text(PAUSES)
    result = compile_file(script)
    assert result.plan is not None
    u = result.plan.utterances[0]
    spans = [(c.start_frame, c.end_frame) for c in u.controls if c.kind == "pause"]
    assert [round((b - a) / FPS) for a, b in spans] == [2, 4]
    pause = np.zeros(u.n_frames, bool)
    for a, b in spans:
        pause[a:b] = True
    t = np.arange(u.n_frames) / FPS
    speaking = np.zeros(u.n_frames, bool)
    for w in u.words:
        speaking |= (t >= w.start) & (t < w.end)
    speaking &= ~pause
    a, b = spans[1]
    mid_gap = np.zeros(u.n_frames, bool)
    mid_gap[a + FPS:b - FPS] = True  # the long gap less a second at each end (arms going down and up)
    wrists = [JOINTS.index("left_wrist"), JOINTS.index("right_wrist")]
    inputs = EngineInputs.from_plan(u)
    for seed in range(3):
        speed = np.r_[0.0, joint_speeds(neural.generate(inputs, seed=seed))[:, wrists].mean(axis=1)]
        assert np.median(speed[pause]) <= np.median(speed[speaking])
        assert speed[pause].mean() <= speed[speaking].mean()
        assert speed[pause].max() <= speed[speaking].max()
        assert speed[mid_gap].mean() < 0.5 * speed[speaking].mean()

"""The take's posture and drift (model/take_posture.py): weights carry their training takes'
postures and slow drifts, generation draws one take per speaker and moves the network's output
by them, giving way to requested poses, space and handedness."""

from pathlib import Path

import numpy as np
import pytest

from core.controls import STYLE_INDEX, ControlArrays
from core.skeleton import N_BONES, REST_POSE
from model import take_posture

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "mall_guide.sgt"
LONG_LINE = ("guide: Welcome to the north wing of the mall, where you will find the bookshop, two cafes and a small "
             "cinema that shows old films every Sunday afternoon, so take your time and enjoy the walk.\n")


def _takes(n=4, drifts=False):
    postures = np.repeat(np.linspace(-0.2, 0.2, n, dtype=np.float32)[:, None], 27, axis=1)
    if not drifts:
        return take_posture.Takes(postures)
    rng = np.random.default_rng(n)
    return take_posture.Takes(postures, tuple(rng.uniform(-0.1, 0.1, (3 + i, 27)).astype(np.float32) for i in range(n)))


def test_draw_is_deterministic_per_key_and_uses_every_take():
    takes = _takes()
    assert take_posture.draw(None, 3) is None and take_posture.draw(take_posture.Takes(np.zeros((0, 27))), 3) is None
    draws = [take_posture.draw(takes, (7, k)) for k in range(40)]
    assert {float(d.posture[0]) for d in draws} == {float(v) for v in takes.postures[:, 0]}  # every take can be drawn
    assert np.array_equal(take_posture.draw(takes, (7, 3)).posture, take_posture.draw(takes, (7, 3)).posture)
    assert np.array_equal(take_posture.draw(takes, 5).posture, take_posture.draw(takes, (5,)).posture)
    # a take's drift comes with its posture
    takes = _takes(drifts=True)
    for d in (take_posture.draw(takes, (7, k)) for k in range(12)):
        i = int(np.flatnonzero(takes.postures[:, 0] == d.posture[0])[0])
        assert d.drift is takes.drifts[i]


def test_a_speaker_keeps_its_key_whatever_other_speakers_say():
    a = take_posture.speaker_key(4, "guide")
    assert a == take_posture.speaker_key(4, "guide") and a != take_posture.speaker_key(4, "visitor")
    assert a != take_posture.speaker_key(5, "guide")
    assert take_posture.speaker_key(4, None) == take_posture.speaker_key(4, "")
    take_posture.speaker_key(1, "b\udc80d")  # a name that is not UTF-8 still has a key


def test_the_posture_gives_way_to_requested_poses_space_and_handedness():
    arrays = ControlArrays.empty(30)
    assert take_posture.posture_weight(arrays).tolist() == [1.0] * 30
    arrays.pose_mask[10] = 1.0
    arrays.style_mask[25:, STYLE_INDEX["handedness"]] = 1.0
    arrays.style_mask[:, STYLE_INDEX["speed"]] = 1.0  # speed does not hold it
    w = take_posture.posture_weight(arrays)
    assert w[10] == 0 and w[25:].max() == 0
    assert w[0] == 1 and 0 < w[13] < w[15] < 1 and w[17] == 1  # eased over POSTURE_RAMP frames
    assert np.all(np.diff(w[10:18]) >= 0) and np.all(np.diff(w[17:26]) <= 0)
    arrays.style_mask[:, STYLE_INDEX["space"]] = 1.0
    assert not take_posture.posture_weight(arrays).any()


def test_posture_moves_the_bones_and_keeps_them_unit_length():
    poses = np.repeat(np.asarray(REST_POSE, np.float32)[None], 5, 0)
    posture = take_posture.Take(np.linspace(-0.3, 0.3, 27).astype(np.float32))
    moved = take_posture.with_posture(poses, posture)
    assert np.allclose(np.linalg.norm(moved.reshape(5, N_BONES, 3), axis=-1), 1, atol=1e-5)
    assert np.abs(moved - poses).max() > 0.1
    half = take_posture.with_posture(poses, posture, np.array([0, 0, 0.5, 1, 1]))
    assert np.array_equal(half[:2], poses[:2]) and np.allclose(half[3:], moved[3:])
    assert take_posture.with_posture(poses, None) is poses
    assert take_posture.with_posture(poses, posture, np.zeros(5)) is poses


def test_takes_read_back_and_refuse_damaged_values():
    takes = _takes()
    back = take_posture.Takes.from_dict(takes.as_dict())
    assert np.allclose(back.postures, takes.postures, atol=1e-4) and back.drifts is None
    for bad in ("wide", {}, {"postures": [[0.1] * 26]}, {"postures": [[float("nan")] * 27]}, {"postures": [[2.0] * 27]},
                {"postures": [["a"] * 27]}):
        with pytest.raises(take_posture.TakesError):
            take_posture.Takes.from_dict(bad)


def test_drifts_read_back_and_damaged_ones_are_refused():
    import base64

    takes = _takes(drifts=True)
    blob = takes.as_dict()
    back = take_posture.Takes.from_dict(blob)
    assert [len(d) for d in back.drifts] == [len(d) for d in takes.drifts]
    for a, b in zip(back.drifts, takes.drifts):
        assert np.allclose(a, b, atol=1e-3)  # float16
    raw = np.frombuffer(base64.b64decode(blob["drift"]["float16"]), "<f2").copy()

    def damaged(**change):
        return {**blob, "drift": {**blob["drift"], **change}}

    def packed(values):
        return base64.b64encode(values.astype("<f2").tobytes()).decode()

    nan, far = raw.copy(), raw.copy()
    nan[5], far[5] = np.nan, 3.0
    for bad, why in ((damaged(lengths=[3, 4, 5]), "do not match"), (damaged(lengths=[0, 4, 5, 12]), "do not match"),
                     (damaged(float16="not base64!"), "base64"), (damaged(step=2), "sampled every 2"),
                     (damaged(float16=packed(nan)), "not numbers"), (damaged(float16=packed(far)), "within"),
                     ({**blob, "drift": "x"}, "base64")):
        with pytest.raises(take_posture.TakesError, match=why):
            take_posture.Takes.from_dict(bad)


def test_a_drift_is_interpolated_between_its_samples_and_mirrored_past_the_take():
    step = take_posture.DRIFT_STEP
    drift = np.zeros((4, 27), np.float32)
    drift[:, 0] = [0.0, 0.3, -0.3, 0.6]
    take = take_posture.Take(np.full(27, 0.05, np.float32), drift)
    off = take.drift_at(np.arange(10 * step))
    assert np.allclose(off[:, 1:], 0.0)
    assert np.allclose(off[[0, step, 2 * step, 3 * step], 0], drift[:, 0])  # the samples
    assert np.isclose(off[step // 2, 0], 0.15, atol=0.3 / step)  # between them, interpolated
    span = 3 * step
    assert np.allclose(off[span + 1 : 2 * span + 1, 0], off[span - 1 :: -1, 0][:span])  # back from the end
    assert np.allclose(off[2 * span, 0], off[0, 0])  # and forth again
    assert np.abs(np.diff(off[:, 0])).max() <= np.abs(np.diff(drift[:, 0])).max() / step + 1e-6  # never a jump
    assert np.allclose(take.drift_at(np.arange(12, 19)), off[12:19])  # a later start is the same track
    assert np.allclose(take_posture.Take(take.posture).drift_at(np.arange(3)), 0.0)  # no drift: nothing
    # with_posture adds the posture (weight) and the drift (its own weight) at the clock's frames
    poses = np.repeat(np.asarray(REST_POSE, np.float32)[None], 8, 0)
    frames = np.array([0, 1, 2, 2, 2, 3, 4, 5])
    w, wd = np.ones(8, np.float32), np.array([1, 1, 1, 1, 0, 0, 1, 1], np.float32)
    moved = take_posture.with_posture(poses, take, w, frames, wd)
    from core.skeleton import normalize_pose
    want = normalize_pose(poses + take.posture + wd[:, None] * take.drift_at(frames))
    assert np.allclose(moved, want, atol=1e-6)
    assert np.allclose(take_posture.with_posture(poses, take), normalize_pose(poses + take.posture + take.drift_at(np.arange(8))))


def test_the_drift_stands_still_in_pauses_and_gives_way_to_a_slower_speed():
    from core.words import TimedWord

    words = [TimedWord("so", 0.0, 0.1), TimedWord("then", 0.7, 0.8), TimedWord("go", 0.85, 1.0)]
    clock = take_posture.drift_clock(20, 3, words)
    from model.postprocess import pause_frames

    quiet = pause_frames(words, 20)
    assert quiet.any() and clock[0] == 3
    assert np.all(np.diff(clock)[quiet[:-1]] == 0) and np.all(np.diff(clock)[~quiet[:-1]] == 1)
    assert np.array_equal(take_posture.drift_clock(6, 2), np.arange(2, 8))  # no words: it runs
    arrays = ControlArrays.empty(30)
    k = STYLE_INDEX["speed"]
    arrays.style_mask[20:, k], arrays.style[20:, k] = 1.0, -1.0
    arrays.style_mask[:8, k], arrays.style[:8, k] = 1.0, 2.0
    assert take_posture.posture_weight(arrays).min() == 1  # the posture stays
    wd = take_posture.drift_weight(arrays)
    assert wd[20:].max() == 0 and wd[10] == 1 and 0 < wd[16] < 1  # the drift eases out before a slower speed
    assert wd[:8].min() == 1  # and stays for a faster one


def test_an_utterance_starts_the_drift_where_its_words_say():
    from core.words import TimedWord

    a = [TimedWord("hello", 0.1, 0.4), TimedWord("there", 0.5, 0.9)]
    b = [TimedWord("good", 0.1, 0.4), TimedWord("bye", 0.5, 0.9)]
    assert take_posture.drift_start(a) == take_posture.drift_start(list(a))
    assert take_posture.drift_start(a) != take_posture.drift_start(b)
    assert take_posture.drift_start([]) == 0


def test_weights_keep_their_takes_and_damaged_ones_are_refused(tmp_path):
    pytest.importorskip("torch")
    import torch

    from model.net import GestureNet
    from model.weights import WeightsError, load_weights, save_weights, set_takes, takes_of

    path = tmp_path / "w.pt"
    save_weights(path, GestureNet({"hidden": 16, "layers": 1, "gru": 0}))
    assert takes_of(path, load_weights(path)[1]) is None  # files without them stay readable
    set_takes(path, _takes())
    assert np.allclose(takes_of(path, load_weights(path)[1]).postures, _takes().postures, atol=1e-4)
    blob = torch.load(str(path), weights_only=True)
    blob["takes"]["postures"][0][1] = 7.0
    torch.save(blob, str(tmp_path / "bad.pt"))
    with pytest.raises(WeightsError, match="damaged training takes"):
        load_weights(tmp_path / "bad.pt")


def test_a_takes_posture_is_what_the_network_leaves_out_of_its_mean_pose():
    pytest.importorskip("torch")
    from synthetic import synthetic_clips

    from model.net import GestureNet
    from model.neural import run_windows
    from model.training.takes import measure_takes

    from scipy.ndimage import gaussian_filter1d

    clips = synthetic_clips(3, seed=2)
    net = GestureNet({"hidden": 16, "layers": 1, "gru": 0}).eval()
    takes = measure_takes(net, clips)
    assert len(takes) == 3 and len(takes.drifts) == 3
    for i, clip in enumerate(clips):
        raw = run_windows(net, clip["audio"], clip["word_ids"], clip["onsets"], ControlArrays.empty(len(clip["poses"])), i)
        assert np.allclose(takes.postures[i], clip["poses"].mean(0) - raw.mean(0), atol=1e-4)
        # the drift: reference minus network, both low-passed, less the posture, every DRIFT_STEP frames
        def low(x):
            return gaussian_filter1d(np.asarray(x, np.float64), take_posture.DRIFT_SIGMA, axis=0, mode="nearest")
        slow = (low(clip["poses"]) - low(raw) - takes.postures[i])[:: take_posture.DRIFT_STEP]
        bones = slow.reshape(len(slow), -1, 3)
        norm = np.linalg.norm(bones, axis=-1, keepdims=True)
        slow = (bones * np.minimum(1, take_posture.DRIFT_LIMIT / norm)).reshape(slow.shape)  # long bones shortened
        assert takes.drifts[i].shape == slow.shape and np.allclose(takes.drifts[i], slow, atol=1e-4)
        assert np.abs(slow).max() > 1e-3  # there is something to carry
        drift_norms = np.linalg.norm(takes.drifts[i].reshape(len(slow), -1, 3), axis=-1)
        assert drift_norms.max() <= take_posture.DRIFT_LIMIT + 1e-5


def test_each_speaker_of_a_performance_draws_one_take():
    from dsl.compiler import compile_file
    from model.generate import EngineInputs

    plan = compile_file(EXAMPLE).plan
    keys = {}
    for u in plan.utterances:
        key = EngineInputs.from_plan(u, 11).take_key
        assert keys.setdefault(u.speaker, key) == key
    assert len(set(keys.values())) == len(keys) >= 1
    assert EngineInputs.from_plan(plan.utterances[0]).take_key is None  # no base seed: the engine's seed draws it


@pytest.fixture(scope="module")
def shipped():
    pytest.importorskip("torch")
    from model.runtime import load_runner

    return load_runner(None)


def test_the_shipped_weights_carry_their_training_takes(shipped):
    from model.weights import DEFAULT_WEIGHTS, load_weights, takes_of

    takes = takes_of(DEFAULT_WEIGHTS, load_weights(DEFAULT_WEIGHTS)[1])
    assert len(takes) >= 100 and takes.drifts is not None and len(takes.drifts) == len(takes)
    assert np.abs(takes.postures).mean() > 0.02 and takes.postures.std(axis=0).mean() > 0.02  # the takes differ
    assert np.mean([np.abs(d).mean() for d in takes.drifts]) > 0.005  # and they wander
    assert np.array_equal(shipped.takes.postures, takes.postures)  # the runner in use has them (ONNX export or torch)
    assert all(np.array_equal(a, b) for a, b in zip(shipped.takes.drifts, takes.drifts))


def test_takes_differ_by_seed_as_the_training_takes_do_and_requests_win(shipped, tmp_path):
    from dsl.compiler import compile_file
    from model import neural
    from model.generate import EngineInputs
    from model.style import style

    script = tmp_path / "long.sgt"
    script.write_text(LONG_LINE)
    inputs = EngineInputs.from_plan(compile_file(script).plan.utterances[0])  # no controls, 11 s
    seeds = range(8)

    def takes(**opts):
        return [neural.generate(inputs, seed=s, options=neural.Options(**opts)) for s in seeds]

    drawn, plain = takes(), takes(take_posture=False)
    # without takes the network holds about the same posture whatever the seed; with them the
    # takes differ as the drawn training takes do
    mean_pose = [np.array([m.mean(0) for m in ms]) for ms in (drawn, plain)]
    assert mean_pose[0].std(axis=0).mean() > 3 * mean_pose[1].std(axis=0).mean()
    wanted = np.array([take_posture.draw(shipped.takes, s).posture for s in seeds])
    got = mean_pose[0] - mean_pose[1]
    assert np.corrcoef(wanted.ravel(), got.ravel())[0, 1] > 0.8
    # a space request in the script: no posture there, the network's own take
    k = STYLE_INDEX["space"]
    arrays = ControlArrays.empty(inputs.n_frames)
    arrays.style[:, k], arrays.style_mask[:, k] = -2.0, 1.0
    asked = EngineInputs(arrays, inputs.words, inputs.audio_path, inputs.lead_in)
    for s in (0, 3):
        assert np.array_equal(neural.generate(asked, seed=s), neural.generate(asked, seed=s, options=neural.Options(take_posture=False)))
    assert float(style(neural.generate(asked, seed=0))[:, k].mean()) < -1.0


def test_record_takes_says_what_is_wrong_without_a_traceback(tmp_path):
    import subprocess
    import sys

    script = Path(__file__).resolve().parent.parent / "scripts" / "record_takes.py"
    run = subprocess.run([sys.executable, str(script), f"--corpus={tmp_path / 'none'}", str(tmp_path / "w.pt")],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 1 and "cannot load the corpus" in run.stderr and "Traceback" not in run.stderr

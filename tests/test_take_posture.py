"""The take's posture (model/take_posture.py): weights carry their training takes' postures,
generation draws one take per speaker and moves the network's output by its posture, which
gives way to requested poses, space and handedness."""

from pathlib import Path

import numpy as np
import pytest

from core.controls import STYLE_INDEX, ControlArrays
from core.skeleton import N_BONES, REST_POSE
from model import take_posture

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "mall_guide.sgt"
LONG_LINE = ("guide: Welcome to the north wing of the mall, where you will find the bookshop, two cafes and a small "
             "cinema that shows old films every Sunday afternoon, so take your time and enjoy the walk.\n")


def _takes(n=4):
    return take_posture.Takes(np.repeat(np.linspace(-0.2, 0.2, n, dtype=np.float32)[:, None], 27, axis=1))


def test_draw_is_deterministic_per_key_and_uses_every_take():
    takes = _takes()
    assert take_posture.draw(None, 3) is None and take_posture.draw(take_posture.Takes(np.zeros((0, 27))), 3) is None
    draws = [take_posture.draw(takes, (7, k)) for k in range(40)]
    assert {float(d[0]) for d in draws} == {float(v) for v in takes.postures[:, 0]}  # every take can be drawn
    assert np.array_equal(take_posture.draw(takes, (7, 3)), take_posture.draw(takes, (7, 3)))
    assert np.array_equal(take_posture.draw(takes, 5), take_posture.draw(takes, (5,)))


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
    posture = np.linspace(-0.3, 0.3, 27).astype(np.float32)
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
    assert np.allclose(back.postures, takes.postures, atol=1e-4)
    for bad in ("wide", {}, {"postures": [[0.1] * 26]}, {"postures": [[float("nan")] * 27]}, {"postures": [[2.0] * 27]},
                {"postures": [["a"] * 27]}):
        with pytest.raises(take_posture.TakesError):
            take_posture.Takes.from_dict(bad)


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

    clips = synthetic_clips(3, seed=2)
    net = GestureNet({"hidden": 16, "layers": 1, "gru": 0}).eval()
    takes = measure_takes(net, clips)
    assert len(takes) == 3
    for i, clip in enumerate(clips):
        raw = run_windows(net, clip["audio"], clip["word_ids"], clip["onsets"], ControlArrays.empty(len(clip["poses"])), i)
        assert np.allclose(takes.postures[i], clip["poses"].mean(0) - raw.mean(0), atol=1e-4)


def test_each_speaker_of_a_performance_draws_one_take():
    from dsl.compiler import compile_file
    from model.generate import EngineInputs

    plan = compile_file(EXAMPLE).plan
    keys = {}
    for u in plan.utterances:
        key = EngineInputs.from_plan(u, None, 11).take_key
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
    assert len(takes) >= 100
    assert np.abs(takes.postures).mean() > 0.02 and takes.postures.std(axis=0).mean() > 0.02  # the takes differ
    assert np.array_equal(shipped.takes.postures, takes.postures)  # the runner in use has them (ONNX export or torch)


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
    wanted = np.array([take_posture.draw(shipped.takes, s) for s in seeds])
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

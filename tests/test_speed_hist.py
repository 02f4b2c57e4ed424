"""The speed-histogram training term (model/training/speed_hist.py, `sgt train --hist-weight`)."""

import json

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from core.skeleton import REST_POSE  # noqa: E402
from model.training import metrics  # noqa: E402
from model.training.speed_hist import soft_speed_hellinger  # noqa: E402


def _batch(amplitude, seed, b=4, t=30):
    rng = np.random.default_rng(seed)
    wave = np.sin(np.linspace(0, 6 * np.pi, t))[None, :, None] * rng.uniform(0.5, 1.5, (b, 1, 27))
    poses = np.asarray(REST_POSE, np.float32)[None, None] + amplitude * wave
    return torch.tensor(poses.astype(np.float32))


def test_it_is_the_hellinger_distance_of_the_speed_histograms():
    still, moving = _batch(0.002, 0), _batch(0.3, 1)
    assert float(soft_speed_hellinger(moving, moving)) < 1e-3
    for a, b in ((0.05, 0.1), (0.1, 0.2), (0.05, 0.3)):  # overlapping histograms: the evaluation's distance
        x, y = _batch(a, 0), _batch(b, 1)
        hard = metrics.hellinger(metrics.speed_histogram(list(x.numpy())), metrics.speed_histogram(list(y.numpy())))
        assert abs(float(soft_speed_hellinger(x, y)) - hard) < 0.08  # up to the soft bins
    assert float(soft_speed_hellinger(still, moving)) > 0.8  # disjoint ones: near 1
    # windows with keep 0 do not count
    mixed = torch.cat([moving[:2], still[2:]])
    keep = torch.tensor([1.0, 1.0, 0.0, 0.0])
    assert float(soft_speed_hellinger(mixed, moving, keep)) < 1e-3 < float(soft_speed_hellinger(mixed, moving))


def test_its_gradient_moves_the_speeds_towards_the_reference():
    x = _batch(0.02, 2).requires_grad_(True)
    ref = _batch(0.3, 3)
    opt = torch.optim.Adam([x], lr=0.01)
    first = float(soft_speed_hellinger(x, ref).detach())
    for _ in range(30):
        opt.zero_grad()
        loss = soft_speed_hellinger(x, ref)
        loss.backward()
        opt.step()
    assert float(soft_speed_hellinger(x, ref).detach()) < 0.7 * first


def test_sgt_train_adds_it_with_its_weight(tmp_path):
    from synthetic import synthetic_clips

    from model.training.train import TrainConfig, train

    clips = synthetic_clips(8, frames=80, seed=1)
    cfg = TrainConfig(epochs=1, steps_per_epoch=3, batch=4, hist=2.0, net={"hidden": 16, "layers": 1, "gru": 0})
    train(clips[:6], clips[6:], tmp_path / "run", cfg, resume=False, log=lambda s: None)
    row = json.loads((tmp_path / "run" / "metrics.jsonl").read_text().splitlines()[-1])
    assert row["hist"] > 0
    off = TrainConfig(epochs=1, steps_per_epoch=3, batch=4, hist=0.0, net={"hidden": 16, "layers": 1, "gru": 0})
    train(clips[:6], clips[6:], tmp_path / "off", off, resume=False, log=lambda s: None)
    assert json.loads((tmp_path / "off" / "metrics.jsonl").read_text().splitlines()[-1])["hist"] == 0
    # the same batches (the term draws no random numbers), so only the term can make the weights differ
    from model.weights import load_weights

    on_w, off_w = (load_weights(tmp_path / run / "last.pt")[0].state_dict() for run in ("run", "off"))
    assert any(not torch.equal(on_w[k], off_w[k]) for k in on_w)


def test_a_checkpoint_made_with_other_settings_is_not_replaced(tmp_path):
    """`sgt train`'s default weight of this term changed (0 -> 2): a run interrupted before
    that no longer resumes with the same command. Training refuses, says which setting
    differs, and leaves the checkpoint as it was; --fresh (resume=False) starts over."""
    from synthetic import synthetic_clips

    from model.training.train import TrainConfig, train

    clips = synthetic_clips(8, frames=80, seed=1)
    net = {"hidden": 16, "layers": 1, "gru": 0}
    train(clips[:6], clips[6:], tmp_path, TrainConfig(epochs=1, steps_per_epoch=2, batch=4, hist=0.0, net=net),
          resume=False, log=lambda s: None)
    before = (tmp_path / "checkpoint.pt").read_bytes()
    now = TrainConfig(epochs=1, steps_per_epoch=2, batch=4, hist=2.0, net=net)
    with pytest.raises(ValueError, match=r"other settings: hist 0\.0 \(now 2\.0\).*--fresh"):
        train(clips[:6], clips[6:], tmp_path, now, log=lambda s: None)
    assert (tmp_path / "checkpoint.pt").read_bytes() == before
    train(clips[:6], clips[6:], tmp_path, now, resume=False, log=lambda s: None)
    said = []
    train(clips[:6], clips[6:], tmp_path, now, log=said.append)
    assert any("resumed from" in s for s in said), said

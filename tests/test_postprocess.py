"""Post-processing (model/postprocess.py): the one centred window mean and the one pose-control
blend (the neural engine, sgt eval and the rules engine use them), checked against the
definitions written out naively here."""

import numpy as np
import pytest

from core.skeleton import N_BONES, normalize_pose
from model import postprocess
from model.style import window_mean


def naive_window_mean(x, window):
    half = window // 2
    return np.stack([x[..., max(0, i - half) : i + half + 1].mean(axis=-1) for i in range(x.shape[-1])], axis=-1)


def test_window_mean_is_the_centred_mean_cut_at_the_ends():
    rng = np.random.default_rng(0)
    for t, window in ((1, 5), (7, 1), (20, 5), (20, 4), (33, 30), (5, 30)):
        x = rng.normal(size=(3, t))
        assert np.allclose(window_mean(x, window), naive_window_mean(x, window), atol=1e-12), (t, window)


def test_moving_average_is_the_window_mean_over_time_renormalised():
    rng = np.random.default_rng(1)
    poses = normalize_pose(rng.normal(size=(40, 27)))
    got = postprocess.moving_average(poses, 5)
    want = normalize_pose(naive_window_mean(poses.astype(np.float64).T, 5).T)
    assert np.allclose(got, want, atol=1e-6)
    assert np.array_equal(postprocess.moving_average(poses, 1), poses)


def test_smoothstep():
    assert postprocess.smoothstep(np.array([-1.0, 0.0, 0.25, 0.5, 1.0, 2.0])).tolist() == [0, 0, 0.15625, 0.5, 1, 1]


def unit(rng, n):
    return normalize_pose(rng.normal(size=(n, 27))).astype(np.float32)


def nlerp(a, b, w):
    return normalize_pose((1 - w) * a + w * b)


def test_blend_is_exact_on_controls_and_eases_over_the_ramp():
    rng = np.random.default_rng(2)
    gen, req = unit(rng, 40), unit(rng, 40)
    mask = np.zeros(40)
    mask[10:13] = 1
    mask[20] = 1
    mask[34] = 1
    out = postprocess.blend_pose_controls(gen, req, mask, ramp=6)
    assert np.allclose(out[mask > 0], req[mask > 0], atol=1e-6)
    for k in range(1, 7):  # k frames before the first span: towards its first pose
        w = postprocess.smoothstep(1 - k / 7)
        assert np.allclose(out[10 - k], nlerp(gen[10 - k], req[10], w), atol=1e-6), k
    for k in range(1, 4):  # after it: from its last pose (up to the frames nearer the next span)
        w = postprocess.smoothstep(1 - k / 7)
        assert np.allclose(out[12 + k], nlerp(gen[12 + k], req[12], w), atol=1e-6), k
    # between two spans a frame eases towards the nearer one, the earlier on a tie (frame 16)
    assert np.allclose(out[18], nlerp(gen[18], req[20], postprocess.smoothstep(1 - 2 / 7)), atol=1e-6)
    assert np.allclose(out[16], nlerp(gen[16], req[12], postprocess.smoothstep(1 - 4 / 7)), atol=1e-6)
    assert np.allclose(out[27], gen[27], atol=1e-6)  # 7 frames from both: untouched
    assert np.allclose(out[:3], gen[:3], atol=1e-6)  # 7+ frames before the first span
    assert np.array_equal(postprocess.blend_pose_controls(gen, req, np.zeros(40)), gen)


def test_blend_ramps_grow_with_the_turn_when_the_step_is_limited():
    a = np.radians(150.0)
    gen = np.tile([1.0, 0.0, 0.0], (40, N_BONES)).astype(np.float32)
    req = np.zeros((40, 27), np.float32)
    req[20] = np.tile([np.cos(a), np.sin(a), 0.0], N_BONES)  # every bone turns 150 degrees
    mask = np.zeros(40)
    mask[20] = 1
    out = postprocess.blend_pose_controls(gen, req, mask, ramp=5, max_step_deg=12.0)
    # ceil(150 / 12) + 1 = 14 frames each side instead of 5
    assert np.flatnonzero(np.abs(out - gen).max(axis=1) > 1e-6).tolist() == list(range(6, 35))
    short = postprocess.blend_pose_controls(gen, req, mask, ramp=5)
    assert np.flatnonzero(np.abs(short - gen).max(axis=1) > 1e-6).tolist() == list(range(15, 26))


def test_a_long_ramp_stops_at_the_neighbouring_span():
    a = np.radians(150.0)
    gen = np.tile([1.0, 0.0, 0.0], (30, N_BONES)).astype(np.float32)
    req = gen.copy()
    req[14] = np.tile([np.cos(a), np.sin(a), 0.0], N_BONES)  # a long ramp on both sides of frame 14
    mask = np.zeros(30)
    mask[[10, 14]] = 1  # frame 10 asks for the generated pose itself
    out = postprocess.blend_pose_controls(gen, req, mask, ramp=2, max_step_deg=12.0)
    assert np.allclose(out[:11], gen[:11], atol=1e-6)  # frame 14's ramp ends at frame 11
    assert np.abs(out[11:14] - gen[11:14]).max() > 0.1 and np.abs(out[15:28] - gen[15:28]).max(axis=1).min() > 0


def test_a_requested_bone_of_zero_length_keeps_the_generated_bone():
    rng = np.random.default_rng(4)
    gen, req = unit(rng, 10), unit(rng, 10)
    req[5, :3] = 0.0
    mask = np.zeros(10)
    mask[5] = 1
    out = postprocess.blend_pose_controls(gen, req, mask, ramp=2)
    assert np.allclose(out[5, :3], gen[5, :3], atol=1e-6) and np.allclose(out[5, 3:], req[5, 3:], atol=1e-6)


@pytest.mark.parametrize("ramp", [0, 3])
def test_blend_without_ramp_or_with_a_short_one(ramp):
    rng = np.random.default_rng(5)
    gen, req = unit(rng, 12), unit(rng, 12)
    mask = np.zeros(12)
    mask[6] = 1
    out = postprocess.blend_pose_controls(gen, req, mask, ramp=ramp)
    changed = np.flatnonzero(np.abs(out - gen).max(axis=1) > 1e-6).tolist()
    assert changed == list(range(6 - ramp, 7 + ramp))

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


def _random_motion(rng, t):
    """A smooth random motion (T, 27) of unit bone directions."""
    steps = rng.normal(0, 0.05, (t, N_BONES * 3)).cumsum(axis=0) + rng.normal(0, 1, N_BONES * 3)
    return normalize_pose(steps)


def test_per_bone_blend_drives_only_the_masked_bones_and_eases_each_one():
    rng = np.random.default_rng(4)
    t = 60
    gen = _random_motion(rng, t)
    req = _random_motion(rng, t)
    mask = np.zeros(t)
    mask[20:40] = 1
    bones = np.zeros((t, N_BONES))
    bones[20:40, 6:9] = 1  # the right arm
    bones[30:40, 1:3] = 1  # the head, later
    out = postprocess.blend_pose_controls(gen, req, mask, ramp=6, bones=bones)
    g, r, o = (a.reshape(t, N_BONES, 3) for a in (gen, req, out))
    assert np.allclose(o[:, [0, 3, 4, 5]], g[:, [0, 3, 4, 5]], atol=1e-6)  # never controlled: untouched
    assert np.allclose(o[20:40, 6:9], r[20:40, 6:9], atol=1e-6)  # controlled: exact (PCS 0)
    assert np.allclose(o[30:40, 1:3], r[30:40, 1:3], atol=1e-6)
    assert np.allclose(o[:23, 1:3], g[:23, 1:3], atol=1e-6)  # the head's own ramp starts 6 frames before 30
    assert not np.allclose(o[24:30, 1:3], g[24:30, 1:3], atol=1e-3)
    # each ramp eases: the weight of the request grows as a smoothstep into the span
    dist_gen = np.linalg.norm(o[14:20, 6] - g[14:20, 6], axis=-1)
    dist_req = np.linalg.norm(o[14:20, 6] - r[20, 6], axis=-1)
    assert (np.diff(dist_gen) > 0).all() and (np.diff(dist_req) < 0).all()
    # a full-body mask gives the same result as the plain blend
    full = np.repeat(mask[:, None], N_BONES, axis=1)
    assert np.allclose(postprocess.blend_pose_controls(gen, req, mask, ramp=6, bones=full),
                       postprocess.blend_pose_controls(gen, req, mask, ramp=6))


def test_the_network_is_left_free_on_partly_controlled_frames():
    """A layered gesture does not reach the network: the bones it leaves free are exactly what
    the generator makes with no gesture at all, the bones it drives exactly the request."""
    torch = pytest.importorskip("torch")
    from core.controls import ControlArrays
    from model import neural
    from model.features import AUDIO_DIM
    from model.net import GestureNet

    torch.manual_seed(0)
    net = GestureNet().eval()
    rng = np.random.default_rng(1)
    t = 100
    audio = rng.normal(0, 1, (t, AUDIO_DIM)).astype(np.float32)
    ids = rng.integers(0, 100, t)
    onsets = (rng.random(t) < 0.1).astype(np.float32)
    free = ControlArrays.empty(t)
    layered = ControlArrays.empty(t)
    request = _random_motion(rng, 30)
    arm = np.zeros(N_BONES, bool)
    arm[6:9] = True
    layered.set_pose(40, request, arm)
    raw_free = neural.run_windows(net, audio, ids, onsets, free, seed=3)
    raw_layered = neural.run_windows(net, audio, ids, onsets, layered, seed=3)
    assert np.array_equal(raw_free, raw_layered)
    out = postprocess.finish(raw_layered, layered.pose, layered.pose_mask, bones=layered.bone_mask)
    ref = postprocess.finish(raw_free, free.pose, free.pose_mask)
    o, f = out.reshape(t, N_BONES, 3), ref.reshape(t, N_BONES, 3)
    assert np.allclose(o[:, :6], f[:, :6], atol=1e-6)
    assert np.allclose(o[40:70, 6:9], request.reshape(30, N_BONES, 3)[:, 6:9], atol=1e-6)
    # a gesture that drives every bone still reaches the network as a pose control
    whole = ControlArrays.empty(t)
    whole.set_pose(40, request)
    assert not np.array_equal(neural.run_windows(net, audio, ids, onsets, whole, seed=3), raw_free)


def test_a_pause_holds_the_pose_the_speaker_paused_in_and_controls_stay_exact():
    """calm_pauses: frames outside pauses are untouched; inside a pause the motion keeps only
    a damped share of its movement around the pose at the pause's start; a pose control inside
    the pause is still followed exactly after the blend."""
    from core.skeleton import FPS, REST_POSE, normalize_pose
    from core.words import TimedWord

    rng = np.random.default_rng(3)
    n = 60
    wave = np.sin(np.arange(n) / 2.0)[:, None] * rng.standard_normal((1, 27)) * 0.5
    raw = normalize_pose(REST_POSE[None] + wave).astype(np.float32)
    words = [TimedWord("one", 0.2, 0.9), TimedWord("two", 2.9, 3.4)]  # a 2 s pause
    quiet = postprocess.pause_frames(words, n)
    assert quiet.sum() == int(np.ceil(2.9 * FPS) - 1 - (np.floor(0.9 * FPS) + 1) + 1) and not quiet[:14].any()
    calm = postprocess.calm_pauses(raw, words)
    assert np.array_equal(calm[~quiet], raw[~quiet])
    inside = np.flatnonzero(quiet)[8:-8]  # away from the eases
    held = raw[np.flatnonzero(quiet)[0] - 1]
    assert np.abs(calm[inside] - held).max() < 0.3 * np.abs(raw[inside] - held).max()
    assert np.abs(np.diff(calm[inside], axis=0)).mean() < 0.3 * np.abs(np.diff(raw[inside], axis=0)).mean()
    pose = np.zeros_like(raw)
    mask = np.zeros(n, np.float32)
    pose[25:30], mask[25:30] = normalize_pose(REST_POSE[None] + 0.4), 1.0
    out = postprocess.finish(raw, pose, mask, smoothing="none", words=words)
    assert np.allclose(out[25:30], pose[25:30], atol=1e-6)


def _swinging(n=120, seed=1):
    """A motion that gestures at about the corpus's mean speed: every coordinate of the rest
    pose swings at its own rate (periods of 0.5 to 1.3 s)."""
    from core.skeleton import REST_POSE

    rng = np.random.default_rng(seed)
    t = np.arange(n)[:, None]
    wobble = 0.025 * np.sin(2 * np.pi * t / rng.uniform(8, 20, size=(1, 27)) + rng.uniform(0, 6, size=(1, 27)))
    return normalize_pose(np.asarray(REST_POSE, np.float64)[None] + wobble).astype(np.float32)


def _requested(n, lo, hi, value):
    style = np.zeros((n, 3), np.float32)
    mask = np.zeros((n, 3), np.float32)
    style[lo:hi, 0], mask[lo:hi, 0] = value, 1.0
    return style, mask


@pytest.mark.parametrize("value", [-1.5, -0.5, 0.5, 2.0])
def test_follow_speed_meets_the_requested_speed_where_it_is_requested(value):
    from model.style import style

    poses = _swinging()
    n = len(poses)
    lo, hi = 30, 90
    req, mask = _requested(n, lo, hi, value)
    out = postprocess.follow_speed(poses, req, mask)
    inner = slice(lo + 15, hi - 15)  # the whole 2 s style window inside the request
    before = style(poses)[inner, 0]
    after = style(out)[inner, 0]
    assert np.abs(after - value).mean() < 0.5 * np.abs(before - value).mean()
    assert np.abs(after - value).mean() < 0.3
    assert np.allclose(np.linalg.norm(out.reshape(n, N_BONES, 3), axis=-1), 1.0, atol=1e-5)
    far = np.r_[0:lo - 20, hi + 20:n]  # beyond the low-pass, the gain average and their sum
    assert np.allclose(out[far], poses[far], atol=1e-6)


def test_follow_speed_without_a_speed_request_changes_nothing():
    poses = _swinging(60, seed=1)
    req, mask = _requested(60, 0, 60, 2.0)
    mask[:, 0] = 0.0
    mask[:, 1] = 1.0  # space is requested, speed is not
    assert np.array_equal(postprocess.follow_speed(poses, req, mask), poses)
    assert np.array_equal(postprocess.finish(poses, np.zeros_like(poses), np.zeros(60), smoothing="none", blend=False,
                                             style=req, style_mask=mask), poses)


def test_follow_speed_keeps_the_timing_of_the_strokes():
    """Strokes stay where they were: the frames where the motion is slowest do not move."""
    from model.training.metrics import joint_speeds

    poses = _swinging(150, seed=2)
    req, mask = _requested(150, 0, 150, 2.0)
    out = postprocess.follow_speed(poses, req, mask)
    a, b = joint_speeds(poses).sum(axis=1), joint_speeds(out).sum(axis=1)
    assert b.mean() > 1.3 * a.mean()
    assert np.corrcoef(a, b)[0, 1] > 0.9


def test_zero_phase_smoothing_keeps_strokes_on_their_frames():
    """A bell of motion: the causal 1-euro filter moves its peak later; run both ways it stays."""
    from core.skeleton import REST_POSE

    t = np.arange(90)
    bell = np.exp(-0.5 * ((t - 45) / 4.0) ** 2)
    poses = np.repeat(np.asarray(REST_POSE, np.float64)[None], len(t), axis=0)
    poses[:, 0] += 0.5 * bell  # one coordinate swings out and back
    poses = normalize_pose(poses)
    peak = int(np.argmax(poses[:, 0]))
    causal = postprocess.one_euro(poses)
    both = postprocess.one_euro_zero_phase(poses)
    assert int(np.argmax(causal[:, 0])) > peak
    assert int(np.argmax(both[:, 0])) == peak
    assert both[:, 0].max() < poses[:, 0].max()  # it still smooths
    # the definition: the filter over the reversed output of the filter
    again = postprocess.one_euro(postprocess.one_euro(poses, postprocess.ZERO_PHASE_MIN_CUTOFF)[::-1],
                                 postprocess.ZERO_PHASE_MIN_CUTOFF)[::-1]
    assert np.allclose(both, again, atol=1e-6)
    assert np.array_equal(postprocess.finish(poses, poses, np.zeros(len(t)), blend=False), both.astype(np.float32))

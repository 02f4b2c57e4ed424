"""Old and new implementations give the same numbers (kept until the old ones are deleted)."""

import numpy as np

from model import postprocess


def test_moving_average_through_window_mean_equals_the_old_one():
    rng = np.random.default_rng(0)
    for _ in range(300):
        t = int(rng.integers(1, 200))
        window = int(rng.integers(0, 12))
        poses = rng.normal(size=(t, 27)).astype(np.float32)
        assert np.array_equal(postprocess.moving_average(poses, window), postprocess._moving_average_before_merge(poses, window))


def _random_case(rng, t):
    """Unit generated poses and a mask of a few spans (single frames too) with unit requested poses."""
    from core.skeleton import normalize_pose

    gen = normalize_pose(rng.normal(size=(t, 27))).astype(np.float32)
    pose = np.zeros((t, 27), np.float32)
    mask = np.zeros(t, np.float32)
    for _ in range(int(rng.integers(0, 5))):
        s = int(rng.integers(0, t))
        e = min(t, s + int(rng.integers(1, 12)))
        mask[s:e] = 1
        pose[s:e] = normalize_pose(rng.normal(size=(e - s, 27)))
    return gen, pose, mask


def test_blend_pose_controls_equals_the_one_neural_and_eval_used():
    rng = np.random.default_rng(1)
    for _ in range(400):
        t = int(rng.integers(1, 120))
        gen, pose, mask = _random_case(rng, t)
        for ramp in (0, 1, 6):
            new = postprocess.blend_pose_controls(gen, pose, mask, ramp)
            old = postprocess._blend_pose_controls_before_merge(gen, pose, mask, ramp)
            assert np.array_equal(new, old), (t, ramp)


def test_blend_pose_controls_equals_the_rules_engines_own_blend():
    from model import teacher

    rng = np.random.default_rng(2)
    worst = 0.0
    for _ in range(400):
        t = int(rng.integers(1, 120))
        gen, pose, mask = _random_case(rng, t)
        bones = pose.reshape(t, 9, 3)
        bones[rng.random((t, 9)) < 0.1] = 0.0  # requested bones of zero length keep the generated bone
        opposite = (rng.random((t, 9)) < 0.1) & (mask[:, None] > 0)
        bones[opposite] = -gen.reshape(t, 9, 3)[opposite]  # and bones turned right round
        new = postprocess.blend_pose_controls(gen, pose, mask, teacher.CONTROL_RAMP, max_step_deg=teacher.CONTROL_RAMP_STEP_DEG)
        old = teacher._control_blend(gen, pose, mask)
        worst = max(worst, float(np.abs(new - old).max()) if t else 0.0)
    assert worst < 1e-5, worst  # float32 against the old float64 arithmetic

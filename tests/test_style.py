"""Style statistics (SGToolkit Eq. 4-6), one implementation for numpy and torch."""

import numpy as np
import pytest

from core.skeleton import FPS, REST_POSE, mirror_pose
from library import load_library
from model.style import WINDOW, StyleStats, fit_stats, load_stats, raw_style, style


@pytest.fixture(scope="module")
def lib():
    return load_library(use_config=False)


def _repeat(clip, n=4):
    return np.concatenate([clip] * n)


def test_shapes_and_window_cut_at_the_ends(lib):
    poses = lib.get("wave").clip().poses
    r = raw_style(poses)
    assert r.shape == (len(poses), 3)
    batched = raw_style(np.stack([poses, poses]))
    assert np.allclose(batched[0], r) and np.allclose(batched[1], r)


def test_still_pose_has_zero_speed_and_no_handedness():
    still = np.repeat(REST_POSE[None], 40, axis=0)
    r = raw_style(still)
    assert np.allclose(r[:, 0], 0, atol=1e-4)  # the norm is smoothed by 1e-6 per joint
    assert np.allclose(r[:, 2], 0, atol=1e-3)


def test_faster_playback_raises_speed(lib):
    g = lib.get("beat_both")
    slow = raw_style(_repeat(g.clip(speed=1).poses, 6))[:, 0].mean()
    fast = raw_style(_repeat(g.clip(speed=3).poses, 18))[:, 0].mean()
    assert fast > 1.8 * slow


def test_space_is_wider_for_open_arms_than_hands_together(lib):
    wide = raw_style(lib.get("open_arms").clip().poses)[:, 1].max()
    narrow = raw_style(lib.get("hands_together").clip().poses)[:, 1].min()
    assert wide > narrow + 0.3


def test_handedness_sign_follows_the_moving_hand(lib):
    right = _repeat(lib.get("beat_right").clip().poses)
    r = raw_style(right)[:, 2].mean()
    l = raw_style(mirror_pose(right))[:, 2].mean()
    assert r < -0.5 and l > 0.5  # negative: right hand moves more (Eq. 6)
    assert np.isclose(r, -l, atol=1e-4)


def test_normalised_values_are_clamped_and_centred():
    stats = StyleStats((0.1, 0.5, 0.0), (0.05, 0.1, 0.5))
    raw = np.array([[0.1, 0.5, 0.0], [10.0, -10.0, 0.25]])
    out = stats.normalize(raw)
    assert np.allclose(out[0], 0, atol=1e-6) and np.allclose(out[1], [3, -3, 0.5])


def test_fit_and_shipped_stats(lib, tmp_path):
    motions = [lib.get(n).clip().poses for n in ("wave", "chop", "nod")]
    s = fit_stats(motions)
    allraw = np.concatenate([raw_style(m) for m in motions])
    assert np.allclose(s.mean, allraw.mean(0)) and np.allclose(s.std, allraw.std(0))
    p = tmp_path / "s.json"
    p.write_text(s.to_json())
    assert load_stats(p) == StyleStats(s.mean, s.std, s.source)
    shipped = load_stats()
    assert all(v > 0 for v in shipped.std)
    assert style(motions[0]).shape == (len(motions[0]), 3)


def test_torch_matches_numpy_and_is_differentiable(lib):
    torch = pytest.importorskip("torch")
    poses = _repeat(lib.get("progressive").clip().poses, 2)
    expected = style(poses)
    t = torch.tensor(poses, dtype=torch.float64, requires_grad=True)
    got = style(t)
    assert np.allclose(got.detach().numpy(), expected, atol=1e-5)
    got.sum().backward()
    assert torch.isfinite(t.grad).all() and t.grad.abs().sum() > 0


def test_statistics_average_over_two_seconds_centred_on_the_frame(lib):
    """Eq. 4-6 over a 2 s window (30 frames at 15 fps) centred on each frame: one step of the
    arms at frame 50 shows in the speed of frames 35..65 only, equally."""
    poses = np.repeat(REST_POSE[None], 100, axis=0)
    clip = lib.get("open_arms").clip()
    poses[50:] = clip.poses[clip.stroke_frame]
    speed = raw_style(poses)[:, 0]
    moving = np.flatnonzero(speed > 1e-3)
    assert moving.tolist() == list(range(35, 66))
    assert np.allclose(speed[moving], speed[50], rtol=1e-6)
    assert WINDOW == 2 * FPS

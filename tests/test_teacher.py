"""The rule-based teacher and the ``rules`` engine."""

from __future__ import annotations

import numpy as np
import pytest

from core.controls import ControlArrays
from core.skeleton import BONE_INDEX, FPS, N_BONES, REST_POSE, mirror_pose
from core.words import TimedWord
from model.generate import EngineInputs, engine_function
from model.style import raw_style
from model.teacher import MAX_STEP_DEG, generate, teach

SENTENCE = [TimedWord("so", 0.3, 0.45), TimedWord("we", 0.45, 0.6), TimedWord("went", 0.6, 0.9), TimedWord("to", 0.9, 1.0), TimedWord("the", 1.0, 1.1),
            TimedWord("market", 1.1, 1.6), TimedWord("and", 1.7, 1.8), TimedWord("bought", 1.8, 2.1), TimedWord("fresh", 2.1, 2.4),
            TimedWord("bread", 2.4, 2.8), TimedWord("for", 2.9, 3.0), TimedWord("dinner", 3.0, 3.5), TimedWord("tonight", 3.6, 4.1)]
N = 75


def steps_deg(p):
    d = np.asarray(p, np.float64).reshape(len(p), N_BONES, 3)
    return np.degrees(np.arccos(np.clip((d[1:] * d[:-1]).sum(-1), -1, 1)))


def test_shape_units_smooth():
    p = teach(SENTENCE, N, rng=np.random.default_rng(0))
    assert p.shape == (N, 27) and p.dtype == np.float32
    assert np.allclose(np.linalg.norm(p.reshape(N, 9, 3), axis=-1), 1, atol=1e-5)
    assert steps_deg(p).max() < 25.0
    assert steps_deg(p).max() <= MAX_STEP_DEG + 0.01
    # it moves: not the rest pose frozen
    assert np.abs(p - REST_POSE).max() > 0.2


def test_deterministic_and_seed_dependent():
    a = teach(SENTENCE, N, rng=np.random.default_rng(3))
    b = teach(SENTENCE, N, rng=np.random.default_rng(3))
    c = teach(SENTENCE, N, rng=np.random.default_rng(4))
    assert np.array_equal(a, b)
    assert np.abs(a - c).max() > 0.05


def test_empty_and_tiny():
    assert teach([], 1, rng=np.random.default_rng(0)).shape == (1, 27)
    p = teach([], 30, rng=np.random.default_rng(0))
    assert np.isfinite(p).all() and steps_deg(p).max() < 25


def test_with_audio():
    from model.features import SAMPLE_RATE

    rng = np.random.default_rng(0)
    y = np.zeros(int(3 * SAMPLE_RATE), np.float32)
    for t in (0.5, 1.2, 2.0):  # three loud syllables
        a = int(t * SAMPLE_RATE)
        y[a:a + 2000] = rng.normal(0, 0.3, 2000)
    words = [TimedWord("alpha", 0.4, 0.9), TimedWord("beta", 1.1, 1.6), TimedWord("gamma", 1.9, 2.5)]
    p = teach(words, 60, audio=y, lead_in=0.2, rng=np.random.default_rng(1))
    assert p.shape == (60, 27) and np.isfinite(p).all() and steps_deg(p).max() < 25


def test_accents_follow_the_loud_syllables_of_the_audio():
    """With audio, each content word's accent is where its audio is loudest, not its onset.

    The words' audio bursts come 0.25 s after their onsets (motion time: audio starts at the
    0.2 s lead-in), so an accent on the onset would be 3-4 frames early."""
    from model.features import SAMPLE_RATE
    from model.teacher import _accents, accent_strength, teach

    rng = np.random.default_rng(0)
    y = np.zeros(int(3 * SAMPLE_RATE), np.float32)
    bursts = (0.62, 1.32, 2.12)  # seconds into the audio
    for t in bursts:
        a = int(t * SAMPLE_RATE)
        y[a:a + 1500] = rng.normal(0, 0.3, 1500)
    lead = 0.2
    words = [TimedWord("alpha", 0.4, 0.9), TimedWord("market", 1.1, 1.6), TimedWord("gamma", 1.9, 2.5)]
    words = [w.shifted(lead) for w in words]
    strength = accent_strength(y, 60, lead)
    got = _accents([(w.word, w.start, w.end) for w in words], 60, strength, np.random.default_rng(0))
    want = [int((t + lead) * FPS) for t in bursts]
    assert [f for f, _ in got] == pytest.approx(want, abs=1)
    onsets = [int(w.start * FPS) for w in words]
    assert all(abs(f - o) >= 3 for (f, _), o in zip(got, onsets))
    no_audio = _accents([(w.word, w.start, w.end) for w in words], 60, None, np.random.default_rng(0))
    assert [f for f, _ in no_audio] == onsets
    # the stored strength (the corpus keeps it for re-running the teacher) gives the same motion as the audio
    with_audio = teach(words, 60, audio=y, lead_in=lead, rng=np.random.default_rng(4))
    assert np.array_equal(teach(words, 60, strength=strength, rng=np.random.default_rng(4)), with_audio)
    assert not np.allclose(teach(words, 60, rng=np.random.default_rng(4)), with_audio)


def upper_arm_height(p):
    d = p.reshape(len(p), N_BONES, 3)
    return np.maximum(d[:, BONE_INDEX["left_elbow"], 1], d[:, BONE_INDEX["right_elbow"], 1])


def test_deictic_word_makes_a_pointing_arm():
    words = [TimedWord("look", 0.5, 0.8), TimedWord("over", 0.8, 1.0), TimedWord("there", 1.0, 1.4), TimedWord("please", 1.5, 2.0)]
    onset = 15
    for seed in range(5):
        p = teach(words, 45, rng=np.random.default_rng(seed), trigger_prob=1.0)
        h = upper_arm_height(p)
        # an arm is raised (upper arm near horizontal) around the word, not before the speech
        assert h[onset - 3:onset + 6].max() > -0.6, seed
        assert h[:3].max() < -0.8, seed
        plain = teach([TimedWord("look", 0.5, 0.8), TimedWord("over", 0.8, 1.0), TimedWord("the", 1.0, 1.4), TimedWord("hill", 1.5, 2.0)], 45,
                      rng=np.random.default_rng(seed), trigger_prob=1.0)
        assert upper_arm_height(plain).max() < -0.6, seed


def test_trigger_probability_zero_gives_no_library_gesture():
    words = [TimedWord("look", 0.5, 0.8), TimedWord("over", 0.8, 1.0), TimedWord("there", 1.0, 1.4)]
    p = teach(words, 45, rng=np.random.default_rng(0), trigger_prob=0.0)
    assert upper_arm_height(p).max() < -0.6


def mean_raw(style, seeds=range(6)):
    return np.mean([raw_style(teach(SENTENCE, N, style=style, rng=np.random.default_rng(s))).mean(0) for s in seeds], 0)


@pytest.mark.parametrize("k,name", [(0, "speed"), (1, "space"), (2, "handedness")])
def test_style_moves_statistics(k, name):
    lo, hi = mean_raw({name: -2.0}), mean_raw({name: 2.0})
    assert hi[k] > lo[k] + 0.1 * abs(lo[k]) + 1e-3, (name, lo, hi)


def test_handedness_sign_and_mirror():
    for seed in range(3):
        p = teach(SENTENCE, N, style={"handedness": 2.5}, rng=np.random.default_rng(seed))
        h = raw_style(p)[:, 2].mean()
        hm = raw_style(mirror_pose(p))[:, 2].mean()
        assert h > 0 and hm < 0
        assert np.isclose(h, -hm, atol=1e-6)
        r = teach(SENTENCE, N, style={"handedness": -2.5}, rng=np.random.default_rng(seed))
        assert raw_style(r)[:, 2].mean() < 0


def half_change(poses, k):
    """How much style statistic ``k`` grows from the first half of the frames to the second."""
    r = raw_style(poses)[:, k]
    return r[N // 2:].mean() - r[: N // 2].mean()


@pytest.mark.parametrize("k,name", [(0, "speed"), (1, "space"), (2, "handedness")])
def test_per_frame_style_arrays_act_on_their_frames(k, name):
    """A style that changes half way changes the motion half way (not its mean over the clip)."""
    rising = np.where(np.arange(N) < N // 2, -3.0, 3.0)
    for seed in range(4):
        up = teach(SENTENCE, N, style={name: rising}, rng=np.random.default_rng(seed))
        down = teach(SENTENCE, N, style={name: -rising}, rng=np.random.default_rng(seed))
        assert up.shape == (N, 27) and steps_deg(up).max() < 25
        assert half_change(up, k) > 0 > half_change(down, k), (name, seed)


# -- the rules engine ----------------------------------------------------------------------------


def raised_pose():
    d = REST_POSE.reshape(9, 3).copy()
    d[BONE_INDEX["right_elbow"]] = [-1.0, 0.0, 0.0]
    d[BONE_INDEX["right_wrist"]] = [0.0, 1.0, 0.0]
    d[BONE_INDEX["left_elbow"]] = [0.3, -0.2, 0.93]
    d[BONE_INDEX["left_wrist"]] = [0.0, 0.2, 0.98]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return d.reshape(27).astype(np.float32)


def test_rules_engine_registered_and_follows_pose_controls():
    arrays = ControlArrays.empty(N)
    target = raised_pose()
    arrays.set_pose(30, np.repeat(target[None], 8, axis=0))
    arrays.set_pose(60, target[None])
    inputs = EngineInputs(arrays, SENTENCE)
    fn = engine_function("rules")
    out = fn(inputs, seed=0)
    assert out.shape == (N, 27)
    assert np.allclose(out[30:38], target, atol=1e-6)
    assert np.allclose(out[60], target, atol=1e-6)
    assert steps_deg(out).max() < 25.0  # smooth into and out of the controlled spans
    assert np.array_equal(out, generate(inputs, seed=0))
    assert np.abs(out[10] - target).max() > 0.3  # far from the spans the teacher moves freely


def test_rules_engine_style_controls_act_on_their_frames():
    for seed in range(4):
        late, early = ControlArrays.empty(N), ControlArrays.empty(N)
        late.set_style(N // 2, N, {"speed": 3.0})
        early.set_style(0, N // 2, {"speed": 3.0})
        assert half_change(generate(EngineInputs(late, SENTENCE), seed=seed), 0) > \
            half_change(generate(EngineInputs(early, SENTENCE), seed=seed), 0), seed


def test_rules_engine_style_controls():
    fast, slow = ControlArrays.empty(N), ControlArrays.empty(N)
    fast.set_style(0, N, {"speed": 3.0})
    slow.set_style(0, N, {"speed": -3.0})
    f = np.mean([raw_style(generate(EngineInputs(fast, SENTENCE), seed=s))[:, 0].mean() for s in range(4)])
    s_ = np.mean([raw_style(generate(EngineInputs(slow, SENTENCE), seed=s))[:, 0].mean() for s in range(4)])
    assert f > s_


@pytest.mark.parametrize("shape,sigma", [((100, 27), 2.5), ((7,), 1.0), ((300, 3), 8.3), ((50, 9), 0.7)])
def test_gauss_smooth_is_scipys_gaussian_filter_with_nearest_edges(shape, sigma):
    from scipy.ndimage import gaussian_filter1d

    from model.postprocess import gauss_smooth as _gauss_smooth

    x = np.random.default_rng(3).normal(size=shape)
    np.testing.assert_allclose(_gauss_smooth(x, sigma), gaussian_filter1d(x, sigma, axis=0, mode="nearest"),
                               rtol=0, atol=1e-12)
    assert _gauss_smooth(x.astype(np.float32), sigma).dtype == np.float32


def test_the_velocity_limit_visits_only_steep_frames_and_decides_as_visiting_all():
    """limit_velocity skips frames whose input step is within the limit (when the frame before
    kept its input); it must give the bits of the frame-by-frame loop it replaced."""
    from model.postprocess import unit_vectors as _unit
    from model.teacher import limit_velocity

    def every_frame(poses, max_deg):
        d = _unit(np.asarray(poses, np.float64).reshape(len(poses), -1, 3).copy())
        lim = np.radians(max_deg)
        for t in range(1, len(d)):
            prev, cur = d[t - 1], d[t]
            cosang = np.clip((prev * cur).sum(-1), -1.0, 1.0)
            ang = np.arccos(cosang)
            over = ang > lim
            if not over.any():
                continue
            p, a = prev[over], ang[over]
            perp = _unit(cur[over] - p * cosang[over][:, None])
            step = np.minimum(a, lim)[:, None]
            d[t, over] = p * np.cos(step) + perp * np.sin(step)
        return d.reshape(len(poses), -1)

    rng = np.random.default_rng(0)
    for trial in range(60):
        x = np.cumsum(rng.standard_normal((int(rng.integers(2, 200)), 27)) * rng.choice([0.01, 0.2, 2.0]), axis=0)
        if trial % 5 == 0:
            x[3:] = x[3]  # a still stretch after a jump
        max_deg = float(rng.choice([3.0, 12.0, 40.0]))
        assert limit_velocity(x, max_deg).tobytes() == every_frame(x, max_deg).tobytes()

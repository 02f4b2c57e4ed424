"""Evaluation metrics (model/metrics.py) and the FGD feature extractor (model/fgd.py)."""

import math
import subprocess
import sys

import numpy as np
import pytest

from core.skeleton import FPS, JOINT_INDEX, REST_POSE, positions_from_pose
from library import load_library
from model.style import style
from model.training import fgd as F
from model.training import metrics as M


@pytest.fixture(scope="module")
def lib():
    return load_library(use_config=False)


def _long(lib, names, reps=1):
    """Library clips played one after another: a motion longer than the evaluation window."""
    return np.concatenate([lib.get(n).clip().poses for n in names] * reps).astype(np.float32)


ORIGINAL_GESTURES = """beat_both beat_left beat_right big bow calm_down celebrate chop clap come_here count_one count_three
count_two cup dismiss emphasis frame hands_together head_shake head_tilt nod offer open_arms point_down point_front
point_left point_right point_self point_up progressive raise_hand reject scratch_head shrug small stop sweep think
thumbs_up wave welcome""".split()


def _still(pose, n):
    return np.repeat(np.asarray(pose, np.float32)[None], n, axis=0)


@pytest.fixture(scope="module")
def moving(lib):
    rng = np.random.default_rng(1)
    # The library's first 41 gestures, named, so that growing the library does not change this data.
    names = sorted(ORIGINAL_GESTURES)
    return [_long(lib, rng.choice(names, 5)) for _ in range(16)]


# ------------------------------------------------------------------ PCS / SCS

def test_pcs_is_zero_for_identical_poses_and_grows_with_the_difference(lib):
    ref = _long(lib, ["wave", "beat_both"])[:30]
    ctrl = M.pose_control(ref)
    # SGToolkit Eq. 8 as sgt eval runs it: 5 frames centred on the middle frame (15 of 30)
    assert np.flatnonzero(ctrl.pose_mask).tolist() == [13, 14, 15, 16, 17]
    assert np.array_equal(ctrl.pose[13:18], ref[13:18]) and not ctrl.pose[:13].any() and not ctrl.pose[18:].any()
    assert np.flatnonzero(M.pose_control(ref[:29]).pose_mask).tolist() == [12, 13, 14, 15, 16]
    with pytest.raises(ValueError, match="does not fit"):
        M.pose_control(ref[:4])
    assert M.pcs(ctrl.pose, ref, ctrl.pose_mask) == 0.0
    rng = np.random.default_rng(0)
    noise = rng.normal(size=ref.shape)
    errs = [M.pcs(ctrl.pose, ref + s * noise, ctrl.pose_mask) for s in (0.01, 0.05, 0.2)]
    assert 0 < errs[0] < errs[1] < errs[2]
    # only controlled frames count: changing frame 0 changes nothing
    other = ref.copy()
    other[0] += 1.0
    assert M.pcs(ctrl.pose, other, ctrl.pose_mask) == 0.0
    # a known difference: every number off by 0.1 on the controlled frames
    assert math.isclose(M.pcs(ctrl.pose, ref + 0.1, ctrl.pose_mask), 0.1, rel_tol=1e-5)
    assert math.isnan(M.pcs(ref, ref, np.zeros(30)))


def test_scs_is_zero_when_the_style_matches_the_request(lib):
    gen = _long(lib, ["wave", "beat_right", "open_arms"])[:30]
    s = style(gen)
    mask = np.ones((30, 3))
    assert M.scs(s, gen, mask) == pytest.approx(0.0, abs=1e-6)
    assert M.scs(s + 0.5, gen, mask) == pytest.approx(0.5, abs=1e-5)
    # only masked elements count
    req = s.copy()
    req[:, 1] += 2.0
    mask_speed = np.zeros((30, 3))
    mask_speed[:, 0] = 1
    assert M.scs(req, gen, mask_speed) == pytest.approx(0.0, abs=1e-6)
    # the paper's SCS control: the reference's own style; a still pose complies worse than the motion
    ctrl = M.style_control(gen)
    still = _still(REST_POSE, 30)
    assert M.scs(ctrl.style, gen, ctrl.style_mask) < 1e-6 < M.scs(ctrl.style, still, ctrl.style_mask)


# ------------------------------------------------------------------ APE and motion statistics

def test_ape_of_a_shifted_motion_equals_the_shift(lib):
    pos = positions_from_pose(_long(lib, ["wave"]))
    shift = np.array([0.03, 0.04, 0.0])  # 5 cm
    assert M.ape(pos, pos) == 0.0
    assert M.ape(pos, pos + shift) == pytest.approx(0.05, abs=1e-9)
    assert M.ape(pos + shift, pos) == pytest.approx(0.05, abs=1e-9)
    # poses are accepted too (positions by forward kinematics)
    poses = _long(lib, ["wave"])
    assert M.ape(poses, poses) == 0.0 and M.ape(poses, _still(REST_POSE, len(poses))) > 0.01


def test_speed_accel_jerk_of_a_sine_match_the_analytic_values():
    amp, freq, seconds = 0.1, 0.5, 20  # 10 cm, 0.5 Hz, 10 whole periods
    t = np.arange(seconds * FPS + 1) / FPS
    pos = np.repeat(positions_from_pose(REST_POSE)[None], len(t), axis=0)
    w = JOINT_INDEX["right_wrist"]
    pos[:, w, 0] += amp * np.sin(2 * np.pi * freq * t)
    omega = 2 * np.pi * freq
    assert M.motion_statistics(pos, groups=()) == {}
    st = M.group_statistics(pos, ["right_wrist"])
    got = {1: st.speed, 2: st.accel, 3: st.jerk}
    for k in (1, 2, 3):
        analytic = amp * omega**k * 2 / np.pi  # mean |d^k/dt^k A sin(wt)| over whole periods
        assert got[k] == pytest.approx(analytic, rel=0.02), (k, got[k], analytic)
    # through the public API: the wrist group averages the moving and the still wrist
    wrists = M.motion_statistics(pos, groups=("wrists",))["wrists"]
    assert wrists.speed == pytest.approx(got[1] / 2, rel=1e-9)
    assert wrists.jerk == pytest.approx(got[3] / 2, rel=1e-9)
    # a still pose has zero speed, acceleration and jerk
    still = M.motion_statistics(_still(REST_POSE, 30))["all"]
    assert still.speed == still.accel == still.jerk == 0.0
    assert M.ratio(2.0, 1.6) == pytest.approx(1.25) and math.isnan(M.ratio(1.0, 0.0))
    assert M.jerk_within_tolerance(1.2) and not M.jerk_within_tolerance(1.3)


def test_faster_playback_has_larger_speed_and_jerk(lib):
    slow = M.motion_statistics(lib.get("beat_both").clip(speed=1).poses)["all"]
    fast = M.motion_statistics(lib.get("beat_both").clip(speed=2).poses)["all"]
    assert fast.speed > 1.5 * slow.speed and fast.accel > 2 * slow.accel and fast.jerk > 2 * slow.jerk


# ------------------------------------------------------------------ Hellinger

def test_hellinger_properties():
    a = np.array([0.5, 0.5, 0, 0])
    b = np.array([0, 0, 0.3, 0.7])
    assert M.hellinger(a, a) == 0.0
    assert M.hellinger(a, b) == pytest.approx(1.0)
    rng = np.random.default_rng(0)
    for _ in range(20):
        p, q = rng.random(10) * (rng.random(10) > 0.3), rng.random(10)
        h = M.hellinger(p, q)
        assert 0.0 <= h <= 1.0 and h == pytest.approx(M.hellinger(q, p))
    assert M.hellinger(2 * a, a) == 0.0  # normalised inside
    assert math.isnan(M.hellinger(np.zeros(4), a))


def test_speed_histograms_use_fixed_bins_and_compare_motions(lib):
    wave = _long(lib, ["wave", "beat_both"])
    h = M.speed_histogram(wave)
    assert len(h) == len(M.HIST_EDGES) - 1 == 60 and h.sum() == pytest.approx(1.0)
    fast = np.concatenate([lib.get("wave").clip(speed=3).poses] * 3)
    assert M.speed_histogram(fast, "wrists")[-1] > 0  # speeds >= 3 m/s land in the last bin
    assert M.speed_hellinger(wave, wave) == 0.0
    still = _still(REST_POSE, len(wave))
    assert M.speed_hellinger(wave, still, "wrists") > 0.5
    assert 0 < M.speed_hellinger(wave, fast, "elbows") <= 1


# ------------------------------------------------------------------ FGD (Fréchet distance)

def test_fgd_grows_with_the_shift_of_the_distribution():
    rng = np.random.default_rng(0)
    base = rng.normal(size=(3000, 8))
    same = M.fgd(base[:1500], base[1500:])
    one = M.fgd(base[:1500], base[1500:] + 0.5)
    two = M.fgd(base[:1500], base[1500:] + 1.0)
    assert same < 0.05 < one < two
    assert one == pytest.approx(8 * 0.25, rel=0.1) and two == pytest.approx(8 * 1.0, rel=0.1)
    # degenerate covariances (still motion gives identical features) stay finite and >= 0
    flat = np.zeros((50, 8))
    assert M.fgd(flat, flat) == pytest.approx(0.0, abs=1e-6)
    assert np.isfinite(M.fgd(flat, base[:50])) and M.fgd(flat, base[:50]) > 4
    with pytest.raises(ValueError):
        M.fgd(base[:1], base)


# ------------------------------------------------------------------ the feature extractor

@pytest.fixture(scope="module")
def extractor(lib, moving):
    clips = [lib.get(n).clip(speed=s).poses for n in sorted(ORIGINAL_GESTURES) for s in (1, 2)]
    return F.train_extractor(clips + moving, epochs=8, seed=0, latent=16, channels=32)


def test_extractor_features_separate_still_poses_from_moving_ones(extractor, lib, moving):
    assert extractor.meta["epochs"] == 8 and extractor.meta["val_mae"] < 0.2
    stills = [_still(m[len(m) // 3], 30) for m in moving] + [_still(lib.get(n).clip().poses[-1], 30) for n in sorted(ORIGINAL_GESTURES)[:16]]
    fs, fm = extractor.features(stills), extractor.features(moving)
    assert fs.shape[1] == fm.shape[1] == 16
    between = M.fgd(fs, fm)
    within = M.fgd(fm[::2], fm[1::2])
    assert between > 3 * within, (between, within)


def test_windows_pad_short_motions_and_cover_the_end(lib):
    short = lib.get("nod").clip().poses
    w = F.windows([short])
    assert w.shape == (1, F.WINDOW, 27) and np.allclose(w[0, -1], short[-1])
    w = F.windows(np.zeros((55, 27), np.float32))
    assert len(w) == 4  # starts 0, 10, 20, and 25 (ends on the last frame)


def test_training_is_deterministic_and_save_load_round_trips(tmp_path, lib):
    clips = [lib.get(n).clip().poses for n in lib.names()[:12]]
    a = F.train_extractor(clips, epochs=3, seed=5, latent=8, channels=16)
    b = F.train_extractor(clips, epochs=3, seed=5, latent=8, channels=16)
    fa = a.features(clips)
    assert np.array_equal(fa, b.features(clips))
    path = tmp_path / "fgd.pt"
    a.save(path)
    assert path.stat().st_size < 1_000_000
    c = F.load(path)
    assert np.allclose(c.features(clips), fa, atol=1e-6) and c.meta["seed"] == 5 and c.config == a.config


def test_bad_extractor_files_give_clear_errors(tmp_path, extractor):
    import torch

    with pytest.raises(F.ExtractorError, match="not found"):
        F.load(tmp_path / "missing.pt")
    good = tmp_path / "good.pt"
    extractor.save(good)
    corrupt = tmp_path / "corrupt.pt"
    corrupt.write_bytes(good.read_bytes()[:200])
    with pytest.raises(F.ExtractorError, match="corrupt"):
        F.load(corrupt)
    blob = torch.load(str(good), weights_only=True)
    for change, message in (({"format": "other"}, "not an sgt FGD"), ({"version": 99}, "version 99"),
                            ({"layout": {**blob["layout"], "window": 64}}, "window")):
        bad = tmp_path / "bad.pt"
        torch.save({**blob, **change}, str(bad))
        with pytest.raises(F.ExtractorError, match=message):
            F.load(bad)


def test_importing_metrics_does_not_import_torch():
    code = "import sys, model.training.metrics, model.training.fgd; print('torch' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# ------------------------------------------------------------------ report and table

def test_report_rows_and_table(extractor, moving):
    refs = [m[:60] for m in moving[:6]]
    static = [_still(REST_POSE, 60) for _ in refs]
    ctrls = []
    for r in refs:
        c = M.style_control(r)
        c.set_pose(28, r[28:33])
        ctrls.append(c)
    rows = M.report({"ground truth": (refs, refs, ctrls), "static mean pose": (refs, static, ctrls),
                     "no controls": (refs, [np.roll(r, 7, axis=0) for r in refs])}, extractor=extractor)
    truth, still, shifted = rows
    for row in rows:
        assert set(M.ROW_KEYS) <= set(row)
    assert truth["fgd"] == pytest.approx(0.0, abs=1e-6) and truth["pcs"] == 0 and truth["scs"] < 1e-6
    assert truth["ape"] == 0 and truth["jerk_ratio"] == 1 and truth["hellinger"] == 0 and truth["jerk_ok"]
    assert still["fgd"] > shifted["fgd"] > 0 and still["pcs"] > 0.01 and still["scs"] > 0.1
    assert still["jerk"] == 0 and not still["jerk_ok"] and still["hellinger_wrists"] > 0.5
    assert math.isnan(shifted["pcs"]) and shifted["ape"] > 0
    table = M.format_table(rows)
    lines = table.splitlines()
    assert all(len(line) <= 100 for line in lines)
    assert lines[0].startswith("condition") and "FGD" in lines[0] and "H wri" in lines[0]
    assert lines[2].startswith("ground truth") and lines[4].startswith("no controls")
    assert "   -" in lines[4]  # PCS of an uncontrolled condition is not applicable
    with pytest.raises(ValueError, match="pairs"):
        M.report({"x": (refs, refs[:2])}, extractor=None)


# ------------------------------------------------------------------ beat alignment

def test_beat_alignment_formula():
    """Li et al.'s score over the motion beats: exp(-d^2 / (2 sigma^2)) of each beat's distance
    to the nearest onset, averaged; sigma 0.1 s at 15 fps."""
    d = 3 / 15  # seconds from the beat at frame 20 to the onset at frame 23
    assert M.beat_alignment([10, 20], [10, 23, 40]) == pytest.approx((1 + math.exp(-d * d / (2 * 0.1 * 0.1))) / 2)
    assert M.beat_alignment([10], [10]) == 1.0
    assert M.beat_alignment([10, 20], []) == 0.0 and math.isnan(M.beat_alignment([], [10]))
    assert M.beat_alignment([10], [12], sigma=0.2) > M.beat_alignment([10], [12], sigma=0.1)


def _arm_strokes(stops, n):
    """A right forearm that swings down and up, coming to rest (zero speed) at each frame in ``stops``."""
    from core.skeleton import BONE_INDEX, N_BONES

    t = np.arange(n, dtype=np.float64)
    # position along a cosine between stops: speed 0 exactly at each stop, fastest half-way
    phase = np.interp(t, stops, np.arange(len(stops)) * np.pi)
    angle = 0.6 * (1 - np.cos(phase)) / 2 + 0.2
    dirs = np.repeat(REST_POSE.reshape(1, N_BONES, 3), n, axis=0).astype(np.float64)
    dirs[:, BONE_INDEX["right_wrist"]] = np.stack([np.zeros(n), -np.cos(angle), np.sin(angle)], -1)
    return dirs.reshape(n, 27)


def test_motion_beats_are_where_strokes_stop():
    stops = [5, 14, 22, 33, 41]
    beats = M.motion_beats(_arm_strokes(stops, 46))
    # a ripple is no beat: the same strokes 50 times smaller stop too gently
    tiny = REST_POSE + 0.02 * (_arm_strokes(stops, 46) - REST_POSE)
    assert len(M.motion_beats(tiny)) == 0 and len(beats) == 4
    # every stop after the first (still from frame 0 to 5: a flat start is no minimum)
    assert beats.tolist() == pytest.approx(stops[1:], abs=1)


def test_audio_onsets_are_where_sounds_start():
    from model.features import SAMPLE_RATE, audio_features

    rng = np.random.default_rng(0)
    y = 0.001 * rng.standard_normal(3 * SAMPLE_RATE).astype(np.float32)
    starts = [0.4, 1.1, 2.0]  # seconds
    for s in starts:
        a = int(s * SAMPLE_RATE)
        y[a:a + 3000] += (0.3 * rng.standard_normal(3000)).astype(np.float32)
    onsets = M.audio_onsets(audio_features(y, 45))
    assert onsets.tolist() == pytest.approx([round(s * FPS) for s in starts], abs=1)


def test_clip_beat_alignment_pools_beats_and_sees_shuffled_audio():
    """Strokes that stop on the sounds' onsets score 1 on those beats (the last stop of each
    clip has no sound: 0; the still start is no beat), so 4/5 in all; against another clip's
    onsets (the shuffled control) far less."""
    from model.features import SAMPLE_RATE, audio_features

    rng = np.random.default_rng(1)

    def clip(starts, n=60):
        y = 0.001 * rng.standard_normal(n * SAMPLE_RATE // FPS + 2000).astype(np.float32)
        for f in starts:
            a = int(f * SAMPLE_RATE / FPS)
            y[a:a + 2500] += (0.3 * rng.standard_normal(2500)).astype(np.float32)
        return audio_features(y, n), _arm_strokes([0] + list(starts) + [n - 1], n)

    (fa, ma), (fb, mb) = clip([9, 20, 31, 44]), clip([14, 26, 38, 51])
    own = M.clips_beat_alignment([ma, mb], [fa, fb])
    swapped = M.clips_beat_alignment([ma, mb], [fb, fa])
    assert own == pytest.approx(4 / 5, abs=0.01) and swapped < 0.25
    beats_a, beats_b = M.motion_beats(ma), M.motion_beats(mb)
    pooled = (M.beat_alignment(beats_a, M.audio_onsets(fa)) * len(beats_a)
              + M.beat_alignment(beats_b, M.audio_onsets(fb)) * len(beats_b)) / (len(beats_a) + len(beats_b))
    assert own == pytest.approx(pooled)

"""Posing by hand: core/ik.py (exact two-bone IK at the skeleton's bone lengths, the swivel, the
joints' limits, the head, torso, shoulders and the forearm's twist) and its twin in the page,
viewer/src/ik.js (run in node on the same poses and targets: the two agree within 1e-6)."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from core import ik
from core.skeleton import BONE_LENGTHS, BONES, JOINT_INDEX, REST_POSE, positions_from_pose
from library import load_library

ROOT = Path(__file__).resolve().parent.parent
NODE = shutil.which("node")


def _poses() -> list[np.ndarray]:
    """The rest pose and every keyframe pose of the built-in library."""
    lib = load_library(use_config=False)
    out = [REST_POSE.astype(np.float64)]
    for g in lib:
        out += [d.reshape(-1).astype(np.float64) for d in g.spec.key_dirs]
    return out


POSES = _poses()


def _joint(pose, name: str) -> np.ndarray:
    return positions_from_pose(pose)[JOINT_INDEX[name]]


def _lengths(pose) -> np.ndarray:
    x = positions_from_pose(pose)
    return np.array([np.linalg.norm(x[JOINT_INDEX[c]] - x[JOINT_INDEX[p]]) for p, c in BONES])


def _targets(rng, shoulder, n, lo, hi):
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return shoulder + d * rng.uniform(lo, hi, size=(n, 1))


@pytest.mark.parametrize("side", ik.SIDES)
def test_a_reachable_target_is_reached_exactly_at_the_bone_lengths(side):
    rng = np.random.default_rng(1)
    lo, hi = ik.reach(side)
    for pose in POSES[::7]:
        shoulder = _joint(pose, f"{side}_shoulder")
        for target in _targets(rng, shoulder, 6, lo + 1e-6, hi - 1e-6):
            got = ik.solve_arm(pose, side, target)
            assert np.abs(_joint(got, f"{side}_wrist") - target).max() < 1e-12
            assert np.allclose(_joint(got, f"{side}_shoulder"), shoulder, atol=1e-15)
            assert np.allclose(_lengths(got), [BONE_LENGTHS[c] for _, c in BONES], atol=1e-12)
            assert np.allclose(np.linalg.norm(got.reshape(9, 3), axis=1), 1.0, atol=1e-15)
            other = [i for i, (_, c) in enumerate(BONES) if c not in (f"{side}_elbow", f"{side}_wrist")]
            assert np.array_equal(got.reshape(9, 3)[other], np.asarray(pose).reshape(9, 3)[other])


@pytest.mark.parametrize("side", ik.SIDES)
def test_an_unreachable_target_goes_to_the_nearest_point_in_reach(side):
    rng = np.random.default_rng(2)
    lo, hi = ik.reach(side)
    pose = POSES[0]
    shoulder = _joint(pose, f"{side}_shoulder")
    # every wrist the arm can reach at its limits: the shell between lo and hi around the shoulder
    dirs = rng.normal(size=(20000, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    reachable = shoulder + dirs * rng.uniform(lo, hi, size=(20000, 1))
    for target in [*_targets(rng, shoulder, 8, hi + 0.01, 2.0), *_targets(rng, shoulder, 8, 0.0, lo - 0.01)]:
        got = _joint(ik.solve_arm(pose, side, target), f"{side}_wrist")
        d = np.linalg.norm(target - shoulder)
        expected = shoulder + (target - shoulder) / d * min(max(d, lo), hi)
        assert np.abs(got - expected).max() < 1e-12
        assert np.linalg.norm(got - target) <= np.linalg.norm(reachable - target, axis=1).min() + 1e-9
        assert ik.ELBOW_FLEXION[0] - 1e-9 <= ik.elbow_flexion(ik.solve_arm(pose, side, target), side) <= ik.ELBOW_FLEXION[1] + 1e-9


def test_the_elbow_stays_within_its_flexion_for_every_target():
    rng = np.random.default_rng(3)
    for side in ik.SIDES:
        shoulder = _joint(POSES[0], f"{side}_shoulder")
        for target in _targets(rng, shoulder, 300, 0.0, 0.8):
            f = ik.elbow_flexion(ik.solve_arm(POSES[0], side, target), side)
            assert ik.ELBOW_FLEXION[0] - 1e-9 <= f <= ik.ELBOW_FLEXION[1] + 1e-9, (target, f)
    assert ik.elbow_flexion(ik.solve_arm(POSES[0], "right", _joint(POSES[0], "right_shoulder")), "right") == pytest.approx(155.0)


@pytest.mark.parametrize("side", ik.SIDES)
def test_the_swivel_turns_the_elbow_about_the_shoulder_wrist_line(side):
    pose = POSES[0]
    shoulder = _joint(pose, f"{side}_shoulder")
    target = shoulder + np.array([-0.1 if side == "right" else 0.1, -0.2, 0.3])
    for angle in (-150.0, -90.0, -30.0, 0.0, 45.0, 120.0, 179.0):
        got = ik.solve_arm(pose, side, target, swivel=angle)
        assert np.abs(_joint(got, f"{side}_wrist") - target).max() < 1e-12
        assert ik.swivel(got, side) == pytest.approx(angle, abs=1e-9)
    # a pole: the elbow as near it as the circle of elbows allows (checked against the whole circle)
    pole = shoulder + np.array([0.0, 0.3, -0.2])
    got = ik.solve_arm(pose, side, target, pole=pole)
    best = min(np.linalg.norm(_joint(ik.solve_arm(pose, side, target, swivel=a), f"{side}_elbow") - pole)
               for a in np.linspace(-180, 180, 3601))
    assert np.linalg.norm(_joint(got, f"{side}_elbow") - pole) <= best + 1e-9
    # with neither, the elbow keeps to where it was: the same target again changes nothing
    again = ik.solve_arm(got, side, target)
    assert np.abs(again - got).max() < 1e-12


def test_the_swivel_is_mirror_symmetric():
    pose = POSES[0]
    right = ik.solve_arm(pose, "right", _joint(pose, "right_shoulder") + [-0.1, -0.2, 0.3], swivel=40.0)
    from core.skeleton import mirror_pose

    left = mirror_pose(right)
    assert ik.swivel(left, "left") == pytest.approx(40.0, abs=1e-9)


def test_the_head_turns_within_its_limits_and_keeps_its_shape():
    for yaw, pitch, roll in [(0, 0, 0), (30, -10, 5), (-65, 3, 0), (80, 60, 40), (-200, -90, 90), (10, 20, -30)]:
        got = ik.set_head(POSES[0], yaw, pitch, roll)
        want = [min(max(v, lo), hi) for v, (lo, hi) in zip((yaw, pitch, roll), ik.HEAD_LIMITS.values())]
        assert ik.head_angles(got) == pytest.approx(want, abs=1e-9)
        nose, top = got.reshape(9, 3)[1], got.reshape(9, 3)[2]
        rest = REST_POSE.reshape(9, 3).astype(np.float64)
        assert float(nose @ top) == pytest.approx(float(rest[1] @ rest[2]) / np.linalg.norm(rest[1]) / np.linalg.norm(rest[2]), abs=1e-6)
        assert np.array_equal(got.reshape(9, 3)[3:], POSES[0].reshape(9, 3)[3:])
    # the library's heads are within the limits (look_right turns 65 degrees, bow nods 38)
    for pose in POSES:
        for v, (lo, hi) in zip(ik.head_angles(pose), ik.HEAD_LIMITS.values()):
            assert lo - 1e-6 <= v <= hi + 1e-6


def test_the_torso_and_the_shoulders_stay_within_their_limits():
    up = np.array([0.0, 1.0, 0.0])
    for d in ([0, 1, 1], [0, 0, 1], [1, -1, 0], [0.1, 1, 0.2], [0, -1, 0]):
        got = ik.set_torso(POSES[0], d)
        neck = got[:3]
        assert math.degrees(math.acos(np.clip(neck @ up, -1, 1))) <= ik.TORSO_LEAN + 1e-9
        assert np.array_equal(got[3:], POSES[0][3:])  # only the torso's bone: the arms hang as they did
    assert ik.set_torso(POSES[0], [0, 1, 0.2])[:3] == pytest.approx(np.array([0, 1, 0.2]) / np.hypot(1, 0.2))
    for side in ik.SIDES:
        out = -1 if side == "right" else 1
        for d in ([out, 1, 0], [out, -1, 0], [out, 0, 1], [out, 0, -1], [-out, 0, 0], [out, 0.3, 0.2]):
            got = ik.set_shoulder(POSES[0], side, d)
            e, p = ik.shoulder_angles(got, side)
            assert ik.SHOULDER_ELEVATION[0] - 1e-9 <= e <= ik.SHOULDER_ELEVATION[1] + 1e-9
            assert ik.SHOULDER_PROTRACTION[0] - 1e-9 <= p <= ik.SHOULDER_PROTRACTION[1] + 1e-9
        got = ik.set_shoulder(POSES[0], side, [out, 0.3, 0.2])
        assert ik.shoulder_angles(got, side) == pytest.approx((math.degrees(math.asin(0.3 / np.sqrt(1.13))), math.degrees(math.atan2(0.2, 1))))


def test_the_forearms_twist_picks_the_named_palm_it_turns_to():
    pose = ik.solve_arm(POSES[0], "right", _joint(POSES[0], "right_shoulder") + [0, -0.05, 0.5])  # held forward
    assert ik.twist_palm(pose, "right", "in", 0) == "in"
    assert ik.twist_palm(pose, "right", "in", 90) == "up"  # supination
    assert ik.twist_palm(pose, "right", "in", -90) == "down"
    assert ik.twist_palm(pose, "right", "up", 180) == "down"
    from core.skeleton import mirror_pose

    left = mirror_pose(pose)
    for degrees in (-120, -90, -30, 0, 45, 90, 150):
        assert ik.twist_palm(left, "left", "in", degrees) == ik.twist_palm(pose, "right", "in", degrees)


def test_bad_input_is_refused_in_one_line():
    with pytest.raises(ValueError, match="27 finite"):
        ik.solve_arm([0.0] * 26, "right", [0, 1, 0])
    with pytest.raises(ValueError, match="side"):
        ik.solve_arm(POSES[0], "middle", [0, 1, 0])
    with pytest.raises(ValueError, match="finite"):
        ik.solve_arm(POSES[0], "right", [np.nan, 1, 0])
    with pytest.raises(ValueError, match="not all 0"):
        ik.set_torso(POSES[0], [0, 0, 0])


# -- the page's copy ------------------------------------------------------------------------------

JS = """
import * as ik from %s;
let input = '';
process.stdin.on('data', (d) => { input += d; });
process.stdin.on('end', () => {
  const out = JSON.parse(input).map(([fn, args]) => {
    try { return ik[fn](...args); } catch (e) { return {error: String(e.message)}; }
  });
  process.stdout.write(JSON.stringify(out));
});
"""


def _cases() -> list[tuple[str, list, object]]:
    """(function, arguments, core/ik.py's answer) on the library's poses and random targets."""
    rng = np.random.default_rng(7)
    cases = []
    for pose in POSES[::9]:
        p = [float(x) for x in pose]
        cases.append(("positions", [p], positions_from_pose(pose)))
        cases.append(("headAngles", [p], ik.head_angles(pose)))
        for side in ik.SIDES:
            sh = _joint(pose, f"{side}_shoulder")
            for target in _targets(rng, sh, 2, 0.0, 0.9):
                t = [float(x) for x in target]
                cases.append(("solveArm", [p, side, t], ik.solve_arm(pose, side, t)))
                a = float(rng.uniform(-180, 180))
                cases.append(("solveArm", [p, side, t, {"swivel": a}], ik.solve_arm(pose, side, t, swivel=a)))
                pole = [float(x) for x in sh + rng.normal(size=3) * 0.3]
                cases.append(("solveArm", [p, side, t, {"pole": pole}], ik.solve_arm(pose, side, t, pole=pole)))
            d = [float(x) for x in rng.normal(size=3)]
            cases.append(("setShoulder", [p, side, d], ik.set_shoulder(pose, side, d)))
            cases.append(("shoulderAngles", [p, side], ik.shoulder_angles(pose, side)))
            cases.append(("swivel", [p, side], ik.swivel(pose, side)))
            cases.append(("elbowFlexion", [p, side], ik.elbow_flexion(pose, side)))
            for palm in ("up", "in", "forward"):
                deg = float(rng.uniform(-180, 180))
                cases.append(("twistPalm", [p, side, palm, deg], ik.twist_palm(pose, side, palm, deg)))
        angles = [float(x) for x in rng.uniform(-100, 100, size=3)]
        cases.append(("setHead", [p, *angles], ik.set_head(pose, *angles)))
        d = [float(x) for x in rng.normal(size=3)]
        cases.append(("setTorso", [p, d], ik.set_torso(pose, d)))
    cases.append(("reach", ["left"], ik.reach("left")))
    return cases


@pytest.mark.skipif(NODE is None, reason="node is not installed")
def test_the_pages_ik_is_core_ik(tmp_path):
    cases = _cases()
    script = tmp_path / "run.mjs"
    script.write_text(JS % json.dumps((ROOT / "viewer" / "src" / "ik.js").as_uri()))
    r = subprocess.run([NODE, str(script)], check=False, input=json.dumps([[fn, args] for fn, args, _ in cases]), capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    assert len(got) == len(cases) > 100
    worst = 0.0
    for (fn, args, want), js in zip(cases, got):
        if isinstance(want, str):
            assert js == want, (fn, args)
            continue
        assert not isinstance(js, dict), (fn, args, js)
        diff = float(np.abs(np.asarray(js, np.float64) - np.asarray(want, np.float64)).max())
        worst = max(worst, diff)
        assert diff < 1e-6, f"{fn}{tuple(args[1:])}: the page's answer is {diff:.2e} from core/ik.py's"
    print(f"the page's IK is within {worst:.1e} of core/ik.py's on {len(cases)} cases")

"""Exports: CSV and BVH read back (BVH by an independent parser, bvhio), JSON/NPZ, CLI errors."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from core.controls import Control
from core.motion import MotionClip, load_motion, save_motion
from core.skeleton import BONE_INDEX, FPS, JOINTS, POSE_DIM, REST_POSE, normalize_pose
from core.words import TimedWord


def _library_clip(names=("wave", "point_right", "open_arms", "shrug", "point_up", "clap"), speeds=(1,),
                  flips=(False,)) -> MotionClip:
    """The gestures ``names`` played one after another at each of ``speeds``, each ``flips``,
    then point_right flipped."""
    from core.hands import concat
    from library import load_library

    lib = load_library(use_config=False)
    clips = [lib.get(n).clip(speed=sp, flip=f) for n in names for sp in speeds for f in flips]
    clips.append(lib.get("point_right").clip(flip=True))
    return MotionClip(poses=np.concatenate([c.poses for c in clips]), words=[TimedWord("hi", 0.0, 0.3)],
                      controls=[Control("pose", "wave", 0, 5)], hands=concat([c.hands for c in clips]))


def _hard_poses(n: int = 40) -> np.ndarray:
    """Random bone directions, plus bones turned exactly against their rest direction."""
    rng = np.random.default_rng(3)
    poses = normalize_pose(rng.normal(size=(n, POSE_DIM)))
    flipped = -REST_POSE.copy()
    half = REST_POSE.copy()
    for bone in ("left_elbow", "right_wrist", "neck"):
        i = BONE_INDEX[bone]
        half[3 * i: 3 * i + 3] = -REST_POSE[3 * i: 3 * i + 3]
    return np.concatenate([poses, flipped[None], half[None], REST_POSE[None]])


def _bvh_positions(path) -> tuple[list[str], np.ndarray, float]:
    """World positions (T, n, 3) of the named joints by bvhio's own forward kinematics."""
    bvhio = pytest.importorskip("bvhio")
    root = bvhio.readAsHierarchy(str(path))
    bvh = bvhio.readAsBvh(str(path))
    names = [j.Name for j, _, _ in root.layout()]
    out = []
    for f in range(bvh.FrameCount):
        root.loadPose(f)
        world = {j.Name: np.array(j.PositionWorld, dtype=np.float64) for j, _, _ in root.layout()}
        out.append([world[n] for n in JOINTS])
    return names, np.array(out), bvh.FrameTime


@pytest.mark.parametrize("make", [_library_clip, lambda: MotionClip(poses=_hard_poses())], ids=["library", "hard"])
def test_bvh_forward_kinematics_reproduces_positions(tmp_path, make):
    from renders.export import write_bvh

    clip = make()
    path = tmp_path / "take.bvh"
    write_bvh(path, clip)
    names, pos, frame_time = _bvh_positions(path)
    assert set(JOINTS) <= set(names)
    assert names[0] == "spine"
    assert abs(frame_time - 1 / FPS) < 1e-6
    assert pos.shape == (clip.n_frames, len(JOINTS), 3)
    err = np.linalg.norm(pos - clip.positions, axis=-1)
    assert err.max() < 1e-3, f"worst joint error {err.max() * 1000:.3f} mm"


def test_bvh_header_and_rest_pose(tmp_path):
    from renders.export import bvh_text

    rest = MotionClip(poses=np.repeat(REST_POSE[None], 3, axis=0))
    text = bvh_text(rest)
    assert text.startswith("HIERARCHY\nROOT spine\n")
    assert "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation" in text
    assert "Frames: 3\nFrame Time: 0.0666667\n" in text
    motion = text.split("Frame Time: 0.0666667\n")[1].split()
    values = np.array(motion, dtype=float).reshape(3, -1)
    assert np.allclose(values[:, :3], [0.0, 1.0, 0.0], atol=1e-6)  # root at the spine
    assert np.allclose(values[:, 3:], 0.0, atol=1e-4)  # the rest pose is all-zero rotations


def test_csv_round_trip(tmp_path):
    from renders.export import write_csv

    clip = _library_clip(("wave",))
    path = tmp_path / "take.csv"
    write_csv(path, clip)
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header = rows[0]
    assert header[:3] == ["frame", "time", "utterance"]
    assert header[3:6] == ["spine_x", "spine_y", "spine_z"]
    assert header[-3:] == ["right_wrist_x", "right_wrist_y", "right_wrist_z"]
    assert len(header) == 3 + 3 * len(JOINTS)
    data = np.array(rows[1:], dtype=float)
    assert data.shape[0] == clip.n_frames
    assert np.array_equal(data[:, 0], np.arange(clip.n_frames))
    assert np.allclose(data[:, 1], np.arange(clip.n_frames) / FPS, atol=1e-6)
    assert np.array_equal(data[:, 2], np.zeros(clip.n_frames))  # one utterance: number 0 throughout
    assert np.allclose(data[:, 3:].reshape(-1, len(JOINTS), 3), clip.positions, atol=1e-5)


# -- command line ----------------------------------------------------------------------------

@pytest.fixture
def motion_file(tmp_path):
    path = tmp_path / "take.npz"
    a = _library_clip(("wave",))
    b = _library_clip(("nod",))
    save_motion(path, [a, b])
    return path, a, b


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_cli_export_motion_files(tmp_path, motion_file, suffix, capsys):
    from sgt_tui.cli import main

    path, a, b = motion_file
    out = tmp_path / f"out{suffix}"
    assert main(["export", str(path), "-o", str(out)]) == 0
    clips = load_motion(out)
    assert len(clips) == 2
    assert np.allclose(clips[1].poses, b.poses, atol=1e-5)
    assert main(["export", str(path), "-o", str(out), "--utterance", "1"]) == 0  # the first: a
    clips = load_motion(out)
    assert len(clips) == 1 and clips[0].words == a.words


def test_cli_export_bvh_and_csv(tmp_path, motion_file):
    from sgt_tui.cli import main

    path, a, b = motion_file
    assert main(["export", str(path), "-o", str(tmp_path / "all.csv")]) == 0
    with open(tmp_path / "all.csv") as f:
        assert sum(1 for _ in f) == 1 + a.n_frames + b.n_frames
    assert main(["export", str(path), "-o", str(tmp_path / "one.bvh"), "--utterance", "2"]) == 0  # the second: b
    _, pos, _ = _bvh_positions(tmp_path / "one.bvh")
    assert np.abs(pos - b.positions).max() < 1e-3


def test_cli_export_errors(tmp_path, motion_file, capsys):
    from sgt_tui.cli import main

    path, _, _ = motion_file
    assert main(["export", str(tmp_path / "nope.json"), "-o", str(tmp_path / "x.bvh")]) == 1  # a missing input: the input's problem
    assert "no such file" in capsys.readouterr().err
    assert main(["export", str(path), "-o", str(tmp_path / "x.fbx")]) == 2
    assert "unknown export type" in capsys.readouterr().err
    assert main(["export", str(path), "-o", str(tmp_path / "x.bvh"), "--utterance", "3"]) == 2
    err = capsys.readouterr().err
    assert "no utterance 3: the motion has 2 (1..2)" in err and "Traceback" not in err
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main(["export", str(bad), "-o", str(tmp_path / "x.csv")]) == 1
    assert "not valid JSON" in capsys.readouterr().err
    assert not (tmp_path / "x.bvh").exists() and not (tmp_path / "x.csv").exists()


def _worst_linear_midpoint_error(euler, rotations, per_turn: bool = False) -> float:
    """Degrees between the rotation a client gets by interpolating the channels linearly
    half-way between two frames and the true half-way rotation, worst over frames and joints.
    With ``per_turn``, each joint's error less its own largest turn in one frame (a joint that
    turns fast, such as a hand rolling round its forearm, may be off by as much as it turns)."""
    from scipy.spatial.transform import Rotation

    worst = 0.0
    for j in range(rotations.shape[1]):
        mid = Rotation.from_euler("ZXY", (euler[:-1, j] + euler[1:, j]) / 2, degrees=True)
        a, b = Rotation.from_matrix(rotations[:-1, j]), Rotation.from_matrix(rotations[1:, j])
        true = a * Rotation.from_rotvec((a.inv() * b).as_rotvec() / 2)
        err = float(np.degrees((true.inv() * mid).magnitude()).max())
        if per_turn:
            err -= float(np.degrees((a.inv() * b).magnitude()).max())
        worst = max(worst, err)
    return worst


def test_bvh_channels_are_continuous_through_a_full_turn(tmp_path):
    """A bone turning steadily twice round a circle: written channels never wrap by 360, the
    same rotations come back, and linear interpolation between frames stays on the motion."""
    from scipy.spatial.transform import Rotation

    from renders.export import bvh_text, euler_zxy, local_rotations, unwrap_euler
    from renders.rigs import SGT

    n = 90
    poses = np.tile(REST_POSE, (n, 1)).astype(np.float32)
    b = BONE_INDEX["right_wrist"] * 3
    ang = np.linspace(0, 4 * np.pi, n)  # two whole turns in the horizontal plane, 8 degrees a frame
    poses[:, b : b + 3] = np.stack([np.cos(ang), np.zeros(n), np.sin(ang)], 1)
    clip = MotionClip(poses=normalize_pose(poses))
    rotations = local_rotations(clip)
    raw = euler_zxy(rotations)
    assert _worst_linear_midpoint_error(raw, rotations) > 170  # the plain decomposition wraps
    e = unwrap_euler(raw)
    same = Rotation.from_euler("ZXY", e.reshape(-1, 3), degrees=True).as_matrix()
    assert np.allclose(same, rotations.reshape(-1, 3, 3), atol=1e-9)
    assert _worst_linear_midpoint_error(e, rotations, per_turn=True) < 1e-6  # within one frame's turn
    forearm = [SGT.index["right_elbow"]]
    assert _worst_linear_midpoint_error(e[:, forearm], rotations[:, forearm]) < 8  # the forearm turns 8 a frame
    rows = np.array([list(map(float, r.split())) for r in bvh_text(clip).split("Frame Time:")[1].splitlines()[1:]])
    assert np.abs(np.diff(rows[:, 3:], axis=0)).max() < 180  # no 360-degree wrap in the file


def test_unwrap_euler_picks_the_alternative_solution_near_gimbal():
    from renders.export import unwrap_euler

    e = np.array([[170.0, 80.0, 10.0], [-10.0, 100.0 - 360.0 + 360.0 - 0.0, -170.0]])  # 2nd = alt form of ~(170, 80, 10)
    e[1] = [-10.0, 100.0, -170.0]
    out = unwrap_euler(e)
    assert np.allclose(out[1], [170.0, 80.0, 10.0])

"""Real-data loaders: BVH parsing, forward kinematics, mapping, units, axes, resampling."""

from __future__ import annotations

import json

import numpy as np
import pytest

from core.skeleton import BONE_INDEX, JOINT_INDEX
from model.training.loaders import (
    LoaderError,
    bvh_positions,
    bvh_to_poses,
    find_takes,
    forward_kinematics,
    load_folder,
    parse_bvh,
    read_bvh,
)

CHAIN = """HIERARCHY
ROOT A
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition %s
  JOINT B
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
1 2 3 %s 0 0 0
0 0 0 0 0 0 0 0 0
"""


def test_two_joint_chain_euler_orders():
    # Z then X (R = Rz Rx): (0,10,0) -> Rx90 -> (0,0,10) -> Rz90 -> (0,0,10)
    b = parse_bvh(CHAIN % ("Zrotation Xrotation Yrotation", "90 90 0"))
    pos, _ = forward_kinematics(b)
    assert b.names == ["A", "B", "B_End"]
    assert np.allclose(pos[0, 0], [1, 2, 3])
    assert np.allclose(pos[0, 1], [1, 2, 13], atol=1e-9)
    assert np.allclose(pos[1, 2], [0, 15, 0])
    # X then Z (R = Rx Rz): (0,10,0) -> Rz90 -> (-10,0,0) -> Rx90 -> (-10,0,0)
    b2 = parse_bvh(CHAIN % ("Xrotation Zrotation Yrotation", "90 90 0"))
    pos2, _ = forward_kinematics(b2)
    assert np.allclose(pos2[0, 1], [-9, 2, 3], atol=1e-9)
    assert np.isclose(b.fps, 30.0, atol=1e-3)


def test_bad_bvh_errors():
    with pytest.raises(LoaderError, match="HIERARCHY"):
        parse_bvh("hello")
    with pytest.raises(LoaderError, match="numbers"):
        parse_bvh((CHAIN % ("Zrotation Xrotation Yrotation", "0 0 0")).replace("0 0 0 0 0 0 0 0 0\n", ""))
    good = CHAIN % ("Zrotation Xrotation Yrotation", "0 0 0")
    assert len(parse_bvh(good).joints) == 3
    # a count that is not one is named, not a crash (was OverflowError / ValueError)
    for bad, what in (("CHANNELS 3", "CHANNELS 1e400"), ("CHANNELS 3", "CHANNELS -1"), ("Frames: 2", "Frames: nan")):
        assert bad in good
        with pytest.raises(LoaderError, match="expected a count"):
            parse_bvh(good.replace(bad, what, 1))
    with pytest.raises(LoaderError, match="OFFSET outside a joint"):
        parse_bvh("HIERARCHY OFFSET 0 0 0")


# -- a full upper body --------------------------------------------------------------------------
# T-pose in centimetres, y up, facing +z, left arm along +x.
JOINTS_YUP = [
    # name, parent, offset (cm)
    ("Hips", None, (0, 100, 0)),
    ("Spine", "Hips", (0, 10, 0)),
    ("Spine1", "Spine", (0, 20, 0)),
    ("Neck", "Spine1", (0, 22, 0)),
    ("Head", "Neck", (0, 10, 0)),
    ("LeftShoulder", "Spine1", (4, 20, 0)),
    ("LeftArm", "LeftShoulder", (14, 0, 0)),
    ("LeftForeArm", "LeftArm", (29, 0, 0)),
    ("LeftHand", "LeftForeArm", (26, 0, 0)),
    ("RightShoulder", "Spine1", (-4, 20, 0)),
    ("RightArm", "RightShoulder", (-14, 0, 0)),
    ("RightForeArm", "RightArm", (-29, 0, 0)),
    ("RightHand", "RightForeArm", (-26, 0, 0)),
]


def body_bvh(to_file=lambda v: v, rot_channel="Zrotation", arm_sign=1.0, root_yaw=(None, 0.0), n=31, fps=30):
    """BVH text; LeftArm rotates about the body's forward axis from 0 to -90 deg (arm down) over the take."""
    children = {}
    for name, parent, off in JOINTS_YUP:
        children.setdefault(parent, []).append((name, off))
    chan_of = {}
    order = []
    lines = ["HIERARCHY"]

    def emit(name, off, depth, root=False):
        ind = "  " * depth
        lines.append(f"{ind}{'ROOT' if root else 'JOINT'} {name}")
        lines.append(f"{ind}{{")
        o = to_file(np.array(off, float))
        lines.append(f"{ind}  OFFSET {o[0]:.6f} {o[1]:.6f} {o[2]:.6f}")
        chans = ["Xposition", "Yposition", "Zposition"] if root else []
        chans += ["Zrotation", "Xrotation", "Yrotation"]
        lines.append(f"{ind}  CHANNELS {len(chans)} {' '.join(chans)}")
        chan_of[name] = chans
        order.append(name)
        kids = children.get(name, [])
        for k, ko in kids:
            emit(k, ko, depth + 1)
        if name == "Head":
            e = to_file(np.array([0, 18.0, 0]))
            lines.append(f"{ind}  End Site\n{ind}  {{\n{ind}    OFFSET {e[0]:.6f} {e[1]:.6f} {e[2]:.6f}\n{ind}  }}")
        lines.append(f"{ind}}}")

    emit("Hips", (0, 100, 0), 0, root=True)
    lines += ["MOTION", f"Frames: {n}", f"Frame Time: {1 / fps:.8f}"]
    for f in range(n):
        row = []
        for name in order:
            for c in chan_of[name]:
                v = 0.0
                if name == "Hips" and c.endswith("position"):
                    v = float(to_file(np.array([0, 100.0, 0]))["XYZ".index(c[0])])
                if name == "Hips" and c == root_yaw[0]:
                    v = root_yaw[1]
                if name == "LeftArm" and c == rot_channel:
                    v = arm_sign * -90.0 * f / (n - 1)
                row.append(f"{v:.6f}")
        lines.append(" ".join(row))
    return "\n".join(lines) + "\n"


def test_upper_body_mapping_units_resampling():
    b = parse_bvh(body_bvh())
    pos = bvh_positions(b)  # (T, 10, 3) metres at 15 fps
    assert pos.shape == (16, 10, 3)  # 31 frames at 30 fps = 1 s -> 16 frames at 15 fps
    j = JOINT_INDEX
    # metres: spine (Spine) -> neck (Neck) is 0.42 m straight up
    assert np.allclose(pos[0, j["neck"]] - pos[0, j["spine"]], [0, 0.42, 0], atol=1e-6)
    # shoulders are the upper-arm roots: left at +x
    assert np.allclose(pos[0, j["left_shoulder"]] - pos[0, j["neck"]], [0.18, -0.02, 0], atol=1e-6)
    assert pos[0, j["left_shoulder"], 0] > 0 > pos[0, j["right_shoulder"], 0]
    # nose in front of the head (+z), head_top above it from the end site
    assert pos[0, j["nose"], 2] > pos[0, j["neck"], 2] + 0.05
    assert np.allclose(pos[0, j["head_top"]] - pos[0, j["neck"]], [0, 0.28, 0], atol=1e-6)
    poses = bvh_to_poses(b)
    d = poses.reshape(-1, 9, 3)
    assert np.allclose(d[0, BONE_INDEX["left_elbow"]], [1, 0, 0], atol=1e-6)  # T-pose
    assert np.allclose(d[-1, BONE_INDEX["left_elbow"]], [0, -1, 0], atol=1e-6)  # arm down at the end
    # resampling: output frame k is source frame 2k (a linear ramp of the angle)
    for k in (3, 7):
        a = np.radians(-90.0 * (2 * k) / 30)
        assert np.allclose(d[k, BONE_INDEX["left_elbow"]], [np.cos(a), np.sin(a), 0], atol=1e-6)
    assert np.allclose(d[:, BONE_INDEX["right_elbow"]], [-1, 0, 0], atol=1e-6)


def test_z_up_and_turned_body_gives_the_same_poses():
    ref = bvh_to_poses(parse_bvh(body_bvh()))
    # file axes: z up, y = -forward (x, y, z) -> (x, -z, y); the body also turned 90 deg about up
    to_file = lambda v: np.array([v[0], -v[2], v[1]])
    # a rotation about our z (forward) by t is a rotation about file -y: Yrotation by -t
    text = body_bvh(to_file, rot_channel="Yrotation", arm_sign=-1.0, root_yaw=("Zrotation", 90.0))
    poses = bvh_to_poses(parse_bvh(text))
    assert poses.shape == ref.shape
    assert np.allclose(poses, ref, atol=1e-5)


def test_mapping_override_and_missing():
    text = body_bvh().replace("LeftHand", "L_Paw")
    with pytest.raises(LoaderError, match="left_wrist"):
        bvh_to_poses(parse_bvh(text))
    p = bvh_to_poses(parse_bvh(text), mapping={"left_wrist": "L_Paw"})
    assert p.shape == (16, 27)


def test_folder_layout_with_audio_and_transcript(tmp_path):
    import soundfile as sf

    for d in ("Motion", "Audio", "Transcripts"):
        (tmp_path / d).mkdir()
    (tmp_path / "Motion" / "take1.bvh").write_text(body_bvh())
    sr = 16000
    t = np.arange(sr) / sr
    sf.write(tmp_path / "Audio" / "take1.wav", (0.2 * np.sin(2 * np.pi * 220 * t)).astype(np.float32), sr)
    (tmp_path / "Transcripts" / "take1.json").write_text(json.dumps(
        [{"word": "hello", "start": 0.1, "end": 0.4}, {"word": "there", "start": 0.5, "end": 0.9}]))
    takes = find_takes(tmp_path)
    assert len(takes) == 1 and takes[0].audio_path and takes[0].timings_path
    (clip,) = load_folder(tmp_path)
    T = len(clip["poses"])
    assert clip["poses"].shape == (16, 27)
    assert clip["audio"].shape[0] == T and clip["word_ids"].shape == (T,)
    assert clip["onsets"].sum() == 2 and clip["meta"]["text"] == "hello there"


def test_read_bvh_missing_file(tmp_path):
    with pytest.raises(LoaderError, match="cannot read"):
        read_bvh(tmp_path / "nope.bvh")


def test_forward_kinematics_matches_bvhio(tmp_path):
    """Cross-check against an independent BVH reader (random rotations on every joint)."""
    bvhio = pytest.importorskip("bvhio")
    lines = body_bvh(root_yaw=("Xrotation", 30.0)).splitlines()
    first = lines.index("MOTION") + 3
    rng = np.random.default_rng(0)
    for k in range(first, len(lines)):
        vals = np.array(lines[k].split(), float)
        vals[3:] += rng.uniform(-40, 40, len(vals) - 3)
        lines[k] = " ".join(f"{v:.5f}" for v in vals)
    path = tmp_path / "x.bvh"
    path.write_text("\n".join(lines) + "\n")
    b = read_bvh(path)
    pos, _ = forward_kinematics(b)
    root = bvhio.readAsHierarchy(str(path))
    for f in (0, 7, 30):
        root.loadPose(f)
        world = {j.Name: np.array(j.PositionWorld, dtype=np.float64) for j, _, _ in root.layout()}
        for i, name in enumerate(b.names):
            if name in world:
                assert np.allclose(world[name], pos[f, i], atol=1e-3), (f, name)


def test_sgt_train_on_a_bvh_folder(tmp_path):
    """`sgt train --data DIR` trains on user-owned BVH takes (one held out) and writes weights."""
    import soundfile as sf

    from model.weights import load_weights
    from sgt_tui.cli import main

    for d in ("Motion", "Audio"):
        (tmp_path / d).mkdir()
    sr = 16000
    for i in range(3):
        (tmp_path / "Motion" / f"take{i}.bvh").write_text(body_bvh(n=121))
        sf.write(tmp_path / "Audio" / f"take{i}.wav", (0.1 * np.random.default_rng(i).standard_normal(4 * sr)).astype(np.float32), sr)
    out = tmp_path / "run"
    rc = main(["train", "--data", str(tmp_path), "-o", str(out), "--epochs", "1", "--steps", "2", "--batch", "4",
               "--hidden", "32", "--no-gru", "--threads", "1"])
    assert rc == 0
    model, info = load_weights(out / "generator.pt")
    assert info["meta"]["epochs_done"] == 1
    assert len(info["takes"]["postures"]) == 2  # the training takes (one of three is held out)
    assert main(["train", "--data", str(tmp_path / "Audio"), "-o", str(out)]) == 1  # no .bvh there: an error, no traceback

"""`sgt library add NAME --from take.bvh|take.glb`: takes from other skeletons become gestures.

The takes are written here on rigs that are not sgt's (other joint names, offsets, units, rest
poses, channel orders and frame rates); the source's own world-space bone directions are
computed by a forward kinematics of this file's, independent of the loader's.
"""

from __future__ import annotations

import math
import os
import pwd
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from core.skeleton import BONE_INDEX, FPS
from library import load_library
from sgt_tui import cli
from test_library_cli import _env, _run  # noqa: F401  (_env: the autouse fixture, a HOME of the test's own)

ROOT = Path(__file__).resolve().parents[1]
#: The arm bones compared (sgt bone -> the source's (parent joint, child joint) roles).
ARMS = {"left_elbow": ("l_arm", "l_fore"), "left_wrist": ("l_fore", "l_hand"),
        "right_elbow": ("r_arm", "r_fore"), "right_wrist": ("r_fore", "r_hand")}



# -- a rig and its take ---------------------------------------------------------------------

#: Roles -> (parent role, offset in the rig's units at its rest pose). Mixamo's proportions
#: (cm, a T-pose: arms along x, collar joints above the shoulders, a neck 6 cm over them).
MIXAMO = {
    "hips": (None, (0, 100, 0)), "spine": ("hips", (0, 10, 0)), "chest": ("spine", (0, 12, 0)),
    "upper_chest": ("chest", (0, 13, 0)), "neck": ("upper_chest", (0, 16, 0)), "head": ("neck", (0, 9, 2)),
    "l_collar": ("upper_chest", (6, 11, -1)), "l_arm": ("l_collar", (12, 0, 0)), "l_fore": ("l_arm", (27, 0, 0)),
    "l_hand": ("l_fore", (25, 0, 0)),
    "r_collar": ("upper_chest", (-6, 11, -1)), "r_arm": ("r_collar", (-12, 0, 0)), "r_fore": ("r_arm", (-27, 0, 0)),
    "r_hand": ("r_fore", (-25, 0, 0)),
}
MIXAMO_NAMES = {"hips": "mixamorig:Hips", "spine": "mixamorig:Spine", "chest": "mixamorig:Spine1",
                "upper_chest": "mixamorig:Spine2", "neck": "mixamorig:Neck", "head": "mixamorig:Head",
                "l_collar": "mixamorig:LeftShoulder", "l_arm": "mixamorig:LeftArm",
                "l_fore": "mixamorig:LeftForeArm", "l_hand": "mixamorig:LeftHand",
                "r_collar": "mixamorig:RightShoulder", "r_arm": "mixamorig:RightArm",
                "r_fore": "mixamorig:RightForeArm", "r_hand": "mixamorig:RightHand"}
#: CMU's ASF names, in inches, an A-pose (arms 45 degrees down), a short neck.
CMU = {
    "hips": (None, (0, 36, 0)), "spine": ("hips", (0, 4, 0)), "chest": ("spine", (0, 4, 0)),
    "upper_chest": ("chest", (0, 4.5, 0)), "neck": ("upper_chest", (0, 3, 0)), "head": ("neck", (0, 3.5, 0.5)),
    "l_collar": ("upper_chest", (1, 2, 0)), "l_arm": ("l_collar", (5, 0, 0)), "l_fore": ("l_arm", (7.5, -7.5, 0)),
    "l_hand": ("l_fore", (6.5, -6.5, 0)),
    "r_collar": ("upper_chest", (-1, 2, 0)), "r_arm": ("r_collar", (-5, 0, 0)), "r_fore": ("r_arm", (-7.5, -7.5, 0)),
    "r_hand": ("r_fore", (-6.5, -6.5, 0)),
}
CMU_NAMES = {"hips": "root", "spine": "lowerback", "chest": "upperback", "upper_chest": "thorax",
             "neck": "lowerneck", "head": "head", "l_collar": "lclavicle", "l_arm": "lhumerus",
             "l_fore": "lradius", "l_hand": "lwrist", "r_collar": "rclavicle", "r_arm": "rhumerus",
             "r_fore": "rradius", "r_hand": "rwrist"}


def _rot(axis: str, deg: np.ndarray) -> np.ndarray:
    a = np.radians(deg)
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    m = {"X": [[o, z, z], [z, c, -s], [z, s, c]], "Y": [[c, z, s], [z, o, z], [-s, z, c]],
         "Z": [[c, -s, z], [s, c, z], [z, z, o]]}[axis]
    return np.moveaxis(np.array(m), [0, 1], [-2, -1])


def _ease(t, t0, t1):
    u = np.clip((t - t0) / (t1 - t0), 0, 1)
    return u * u * (3 - 2 * u)


def _angles(rig: dict, fps: float, seconds: float = 2.0) -> dict[str, np.ndarray]:
    """Each role's local rotation (F, 3, 3): the arms from hanging to a right-arm stroke up and
    forward that ends at 0.9 s and holds, the left arm drifting, the torso swaying."""
    t = np.arange(round(seconds * fps)) / fps
    down_l = -80 - math.degrees(math.atan2(rig["l_fore"][1][1], rig["l_fore"][1][0]))  # hangs 10 degrees out
    up = _ease(t, 0.5, 0.9) - 0.6 * _ease(t, 1.4, 2.0)  # the stroke, then a slow way back
    drift = 0.5 * np.sin(2 * np.pi * t / 2.0)
    eye = np.broadcast_to(np.eye(3), (len(t), 3, 3))
    out = {role: eye for role in rig}
    out["chest"] = _rot("X", 6 * drift) @ _rot("Z", 3 * drift)
    out["neck"] = _rot("Y", 10 * drift)
    out["l_arm"] = _rot("Z", np.full_like(t, down_l) + 20 * drift) @ _rot("Y", -25 * drift)
    out["l_fore"] = _rot("Y", -30 - 20 * drift)
    out["r_arm"] = _rot("Z", -np.full_like(t, down_l) - 110 * up) @ _rot("Y", 60 * up)
    out["r_fore"] = _rot("Y", 25 + 50 * up) @ _rot("X", 20 * up)
    return out


def _euler(m: np.ndarray, order: str) -> np.ndarray:
    """(F, 3, 3) -> degrees of ``order`` ("ZXY": R = Rz Rx Ry), solved numerically exact."""
    from scipy.spatial.transform import Rotation  # lazy: scipy

    return Rotation.from_matrix(m).as_euler(order.upper(), degrees=True)


def _world(rig: dict, local: dict) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    world = {}
    for role, (parent, offset) in rig.items():
        off = np.asarray(offset, dtype=np.float64)
        if parent is None:
            world[role] = (np.broadcast_to(off, (len(local[role]), 3)), local[role])
        else:
            ppos, prot = world[parent]
            world[role] = (ppos + prot @ off, prot @ local[role])
    return world


def _directions(rig: dict, local: dict, frame: int) -> dict[str, np.ndarray]:
    """The source's world-space arm directions at ``frame``, by sgt bone."""
    world = _world(rig, local)
    out = {}
    for bone, (a, b) in ARMS.items():
        d = world[b][0][frame] - world[a][0][frame]
        out[bone] = d / np.linalg.norm(d)
    return out


def write_bvh(path: Path, rig: dict, names: dict, fps: float, *, order: str = "ZXY",
              seconds: float = 2.0, leave_out: tuple[str, ...] = ()) -> dict:
    """A BVH take of ``rig`` (joint names ``names``, rotation channels in ``order``); returns
    the local rotations it holds."""
    local = _angles(rig, fps, seconds)
    roles = [r for r in rig if r not in leave_out and rig[r][0] not in leave_out]
    kids = {r: [k for k in roles if rig[k][0] == r] for r in roles}
    lines, columns = ["HIERARCHY"], []
    rot = " ".join(f"{a}rotation" for a in order)

    def joint(role: str, depth: int) -> None:
        pad = "  " * depth
        parent, offset = rig[role]
        lines.append(f"{pad}{'ROOT' if parent is None else 'JOINT'} {names[role]}")
        lines.append(pad + "{")
        lines.append(f"{pad}  OFFSET {' '.join(f'{x:g}' for x in offset)}")
        if parent is None:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition {rot}")
            columns.append(np.broadcast_to(np.asarray(offset, float), (len(local[role]), 3)))
        else:
            lines.append(f"{pad}  CHANNELS 3 {rot}")
        columns.append(_euler(local[role], order))
        for k in kids[role]:
            joint(k, depth + 1)
        if not kids[role]:
            lines.extend([f"{pad}  End Site", pad + "  {", f"{pad}    OFFSET 0 5 0", pad + "  }"])
        lines.append(pad + "}")

    joint("hips", 0)
    motion = np.concatenate(columns, axis=1)
    lines += ["MOTION", f"Frames: {len(motion)}", f"Frame Time: {1 / fps:.8f}"]
    lines += [" ".join(f"{x:.6f}" for x in row) for row in motion]
    path.write_text("\n".join(lines) + "\n")
    return local


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip(np.dot(a / np.linalg.norm(a), b / np.linalg.norm(b)), -1, 1)))


def _stroke_errors(lib_dir: Path, name: str, want: dict[str, np.ndarray]) -> dict[str, float]:
    lib = load_library([lib_dir], use_config=False)
    assert lib.problems == []
    clip = lib.get(name).clip()
    pose = clip.poses[clip.stroke_frame].reshape(-1, 3)
    return {bone: _angle(pose[BONE_INDEX[bone]], d) for bone, d in want.items()}


def _source_stroke(out: str) -> int:
    import re

    m = re.search(r"the stroke at frame (\d+)", out)
    assert m, out
    return int(m.group(1))


# -- from other skeletons -------------------------------------------------------------------

@pytest.mark.parametrize("rig,names,fps,order", [
    (MIXAMO, MIXAMO_NAMES, 30, "ZXY"),
    (MIXAMO, MIXAMO_NAMES, 60, "ZXY"),
    (CMU, CMU_NAMES, 120, "ZYX"),
])
def test_stroke_matches_the_source_arms(tmp_path, capsys, rig, names, fps, order):
    take = tmp_path / "take.bvh"
    local = write_bvh(take, rig, names, fps, order=order)
    n = len(next(iter(local.values())))
    code, out, err = _run(capsys, "library", "add", "raise_it", "--from", take, "--frames", f"0:{n}",
                          "--to", tmp_path / "lib")
    assert code == 0, err
    stroke = _source_stroke(out)
    # the fastest movement (0.5 s to 0.9 s) ends at its hold: the stroke's frame is near 0.9 s
    assert abs(stroke / fps - 0.9) <= 0.1, out
    errors = _stroke_errors(tmp_path / "lib", "raise_it", _directions(rig, local, stroke))
    assert max(errors.values()) < 3.0, errors
    # resampled to the project's rate: the gesture lasts as long as the span
    clip = load_library([tmp_path / "lib"], use_config=False).get("raise_it").clip()
    assert abs(len(clip.poses) - n / fps * FPS) <= 1.5
    assert f"at {FPS} fps from frames 0:{n} at {fps} fps" in out


def test_stroke_and_frames_options(tmp_path, capsys):
    take = tmp_path / "take.bvh"
    local = write_bvh(take, MIXAMO, MIXAMO_NAMES, 60)
    lib = tmp_path / "lib"
    # a span and a stroke in the take's own frames (60 fps), then the same in seconds
    code, out, err = _run(capsys, "library", "add", "mid", "--from", take, "--frames", "20:100",
                          "--stroke", "37", "--to", lib)
    assert code == 0, err
    assert _source_stroke(out) == 37
    clip = load_library([lib], use_config=False).get("mid").clip()
    assert abs(len(clip.poses) - 80 / 60 * FPS) <= 1.5
    assert (clip.stroke_frame - round((37 - 20) / 60 * FPS)) in (0, 1, -1)
    assert max(_stroke_errors(lib, "mid", _directions(MIXAMO, local, 37)).values()) < 3.0
    code, out, err = _run(capsys, "library", "add", "secs", "--from", take, "--frames", "0.5s:1.5s",
                          "--stroke", "1.2s", "--to", lib)
    assert code == 0, err
    assert _source_stroke(out) == 72 and "frames 30:90" in out
    assert max(_stroke_errors(lib, "secs", _directions(MIXAMO, local, 72)).values()) < 3.0


def test_show_and_render_the_gesture(tmp_path, capsys):
    take = tmp_path / "take.bvh"
    write_bvh(take, MIXAMO, MIXAMO_NAMES, 30)
    lib = tmp_path / "lib"
    assert _run(capsys, "library", "add", "from_take", "--from", take, "--frames", "0:60", "--to", lib)[0] == 0
    code, out, err = _run(capsys, "library", "show", "from_take", "--dir", lib)
    assert code == 0, err
    assert "from_take" in out and "stroke" in out
    script = tmp_path / "s.sgt"
    script.write_text("@library lib\nguide: look [pose:from_take] up there.\n")
    code, out, err = _run(capsys, "check", script)
    assert code == 0, out + err
    code, out, err = _run(capsys, "render", script, "-o", tmp_path / "s.gif")
    assert code == 0, out + err
    assert (tmp_path / "s.gif").stat().st_size > 1000


# -- --map ----------------------------------------------------------------------------------

ODD_NAMES = {role: f"Bone.{k:03d}" for k, role in enumerate(MIXAMO)}


def test_unknown_joints_ask_for_a_map_and_the_map_works(tmp_path, capsys):
    take = tmp_path / "odd.bvh"
    local = write_bvh(take, MIXAMO, ODD_NAMES, 30)
    lib = tmp_path / "lib"
    code, out, err = _run(capsys, "library", "add", "odd", "--from", take, "--frames", "0:60", "--to", lib)
    assert code == 1 and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    assert "odd.bvh" in err and "--map" in err and "Bone.000" in err and "right_wrist" in err
    assert not (lib / "odd.toml").exists()
    roles = {"spine": "chest", "neck": "neck", "head": "head", "left_shoulder": "l_arm",
             "left_elbow": "l_fore", "left_wrist": "l_hand", "right_shoulder": "r_arm",
             "right_elbow": "r_fore", "right_wrist": "r_hand"}
    mapping = tmp_path / "rig.toml"
    mapping.write_text("".join(f'{j} = "{ODD_NAMES[r]}"\n' for j, r in roles.items()))
    code, out, err = _run(capsys, "library", "add", "odd", "--from", take, "--frames", "0:60",
                          "--map", mapping, "--to", lib)
    assert code == 0, err
    stroke = _source_stroke(out)
    assert max(_stroke_errors(lib, "odd", _directions(MIXAMO, local, stroke)).values()) < 3.0


@pytest.mark.parametrize("text,words", [
    ('right_elbow = "Bone.0O1"\n', ["'Bone.0O1'", "right_elbow", "no such joint", "Bone.001"]),
    ('right_elbo = "Bone.001"\n', ["'right_elbo'", "right_elbow"]),
    ("right_elbow = 3\n", ["right_elbow", "joint name"]),
    ('right_elbow = "Bone.001\n', ["rig.toml:1:"]),
    (b"right_elbow = '\xff'\n", ["UTF-8"]),
])
def test_bad_map_files(tmp_path, capsys, text, words):
    take = tmp_path / "odd.bvh"
    write_bvh(take, MIXAMO, ODD_NAMES, 30)
    mapping = tmp_path / "rig.toml"
    (mapping.write_bytes if isinstance(text, bytes) else mapping.write_text)(text)
    code, _, err = _run(capsys, "library", "add", "odd", "--from", take, "--frames", "0:60", "--map", mapping,
                        "--to", tmp_path / "lib")
    assert code == 1 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert all(w in err for w in words), err
    assert not (tmp_path / "lib" / "odd.toml").exists()


# -- bad input ------------------------------------------------------------------------------

LR_NAMES = {**MIXAMO_NAMES, "l_arm": "L_UpperArm", "l_fore": "L_Forearm", "l_hand": "L_Hand",
            "r_arm": "R_UpperArm", "r_fore": "R_Forearm", "r_hand": "R_Hand"}


@pytest.mark.parametrize("names", [MIXAMO_NAMES, LR_NAMES])
def test_a_take_without_a_right_arm(tmp_path, capsys, names):
    take = tmp_path / "onearm.bvh"
    write_bvh(take, MIXAMO, names, 30, leave_out=("r_arm",))
    code, _, err = _run(capsys, "library", "add", "x", "--from", take, "--frames", "0:30", "--to", tmp_path / "lib")
    assert code == 1 and len(err.strip().splitlines()) == 1
    # Mixamo's RightShoulder (a collar joint) is the last name tried for the upper arm: the
    # elbow and the wrist are missing, and the line offers no joint of the left arm for them
    assert "right_elbow, right_wrist" in err and "onearm.bvh" in err and "--map" in err
    assert 'right_elbow = "THEIR_NAME"' in err and "L" not in err.split("--map")[1]


@pytest.mark.parametrize("frames,stroke,words", [
    ("0:500", None, ["0:60", "60 frames at 30 fps"]),
    ("40:10", None, ["at least 2 frames"]),
    ("-3:10", None, ["inside 0:60"]),
    ("a:b", None, ["A:B"]),
    ("1e400s:2s", None, ["A:B"]),
    ("0:60", "61", ["outside the span 0:60"]),
    ("10:20", "5", ["outside the span 10:20"]),
    ("0:60", "x", ["--stroke must be a frame number"]),
])
def test_bad_spans(tmp_path, capsys, frames, stroke, words):
    take = tmp_path / "take.bvh"
    write_bvh(take, MIXAMO, MIXAMO_NAMES, 30)
    argv = ["library", "add", "x", "--from", take, f"--frames={frames}", "--to", tmp_path / "lib"]
    code, _, err = _run(capsys, *argv, *(["--stroke", stroke] if stroke else []))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert all(w in err for w in words), err
    assert not (tmp_path / "lib" / "x.toml").exists()


def test_a_span_longer_than_a_gesture(tmp_path, capsys):
    take = tmp_path / "long.bvh"
    write_bvh(take, MIXAMO, MIXAMO_NAMES, 30, seconds=12)
    code, _, err = _run(capsys, "library", "add", "x", "--from", take, "--frames", "0:360", "--to", tmp_path / "lib")
    assert code == 2 and "at most 10 s" in err
    # ten seconds exactly are a gesture's longest: 150 frames
    assert _run(capsys, "library", "add", "x", "--from", take, "--frames", "0:300", "--to", tmp_path / "lib")[0] == 0
    assert len(load_library([tmp_path / "lib"], use_config=False).get("x").clip().poses) == 10 * FPS


@pytest.mark.parametrize("body", [
    b"",
    b"HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n",
    b"\x00\xff" * 100,
    (b"HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n}\nMOTION\nFrames: 2\n"
     b"Frame Time: 0.033\n0 0 nan\n0 0 0\n"),
])
def test_bad_bvh_files(tmp_path, capsys, body):
    take = tmp_path / "bad.bvh"
    take.write_bytes(body)
    code, _, err = _run(capsys, "library", "add", "x", "--from", take, "--frames", "0:2", "--to", tmp_path / "lib")
    assert code == 1 and len(err.strip().splitlines()) == 1 and "bad.bvh" in err and "Traceback" not in err


def test_options_for_takes_only(tmp_path, capsys):
    take = tmp_path / "take.bvh"
    write_bvh(take, MIXAMO, MIXAMO_NAMES, 30)
    code, _, err = _run(capsys, "library", "add", "x", "--from", take, "--frames", "0:30", "--utterance", "1",
                        "--to", tmp_path / "lib")
    assert code == 2 and "--utterance" in err
    code, _, err = _run(capsys, "library", "add", "x", "--from", take, "--frames", "0:30", "--animation", "a",
                        "--to", tmp_path / "lib")
    assert code == 2 and "--animation" in err


def test_a_hostile_take_is_bounded(tmp_path):
    """A 2 MB take of many frames of a deep chain: one line, and the memory stays small."""
    take = tmp_path / "deep.bvh"
    depth = 300
    lines = ["HIERARCHY"]
    for k in range(depth):
        lines += [f"{'ROOT' if k == 0 else 'JOINT'} J{k}", "{", "OFFSET 0 1 0",
                  "CHANNELS 3 Zrotation Xrotation Yrotation" if k else "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    lines += ["}"] * depth
    row = " ".join(["1"] * (3 * depth + 3))
    frames = (2 << 20) // (len(row) + 1)
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.001"] + [row] * frames
    take.write_text("\n".join(lines) + "\n")
    # the peak is the command's own, measured by a small launcher (RUSAGE_CHILDREN): a process
    # forked straight from the suite starts with the suite's resident memory
    launcher = ("import resource, subprocess, sys\n"
                "rc = subprocess.call([sys.executable, '-m', 'sgt_tui.cli'] + sys.argv[1:])\n"
                "print('RSS', resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr)\n"
                "sys.exit(rc)\n")
    r = subprocess.run([sys.executable, "-c", launcher, "library", "add", "x", "--from", str(take),
                        "--frames", f"0:{frames}", "--to", str(tmp_path / "lib")],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path, check=False,
                       env={"PYTHONPATH": str(ROOT), "HOME": str(tmp_path), "PATH": "/usr/bin:/bin"})
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert len(lines) == 2 and "deep.bvh" in lines[0] and "--map" in lines[0]
    rss_mb = int(lines[1].split()[1]) / 1024
    assert rss_mb < 1024, rss_mb


# -- written by Blender ---------------------------------------------------------------------

#: A Mixamo-named armature posed in Blender (z up, facing -y, metres, a T-pose), exported by
#: Blender's own BVH and glTF writers; the world-space bone ends of every frame as Blender
#: computes them go to a JSON file.
BLENDER_RIG = 'import bpy, json, math, sys\nfrom mathutils import Matrix, Vector\nout_bvh, out_glb, out_json, fps = sys.argv[sys.argv.index("--") + 1:]\nfps = int(fps)\nbpy.ops.wm.read_factory_settings(use_empty=True)\nscene = bpy.context.scene\nscene.render.fps = fps\nn = 2 * fps\nscene.frame_start, scene.frame_end = 1, n\ndata = bpy.data.armatures.new("Armature")\narm = bpy.data.objects.new("Armature", data)\nscene.collection.objects.link(arm)\nbpy.context.view_layer.objects.active = arm\nbpy.ops.object.mode_set(mode="EDIT")\n# Mixamo\'s names, metres, a T-pose facing -Y (Blender\'s front), z up\nbones = [("Hips", None, (0, 0, 1.0), (0, 0, 1.1)), ("Spine", "Hips", (0, 0, 1.1), (0, 0, 1.22)),\n         ("Spine1", "Spine", (0, 0, 1.22), (0, 0, 1.35)), ("Spine2", "Spine1", (0, 0, 1.35), (0, 0, 1.51)),\n         ("Neck", "Spine2", (0, 0, 1.51), (0, -0.02, 1.6)), ("Head", "Neck", (0, -0.02, 1.6), (0, -0.02, 1.8)),\n         ("LeftShoulder", "Spine2", (0.06, 0.01, 1.46), (0.18, 0.01, 1.46)),\n         ("LeftArm", "LeftShoulder", (0.18, 0.01, 1.46), (0.45, 0.01, 1.46)),\n         ("LeftForeArm", "LeftArm", (0.45, 0.01, 1.46), (0.70, 0.01, 1.46)),\n         ("LeftHand", "LeftForeArm", (0.70, 0.01, 1.46), (0.78, 0.01, 1.46)),\n         ("RightShoulder", "Spine2", (-0.06, 0.01, 1.46), (-0.18, 0.01, 1.46)),\n         ("RightArm", "RightShoulder", (-0.18, 0.01, 1.46), (-0.45, 0.01, 1.46)),\n         ("RightForeArm", "RightArm", (-0.45, 0.01, 1.46), (-0.70, 0.01, 1.46)),\n         ("RightHand", "RightForeArm", (-0.70, 0.01, 1.46), (-0.78, 0.01, 1.46))]\nfor name, parent, head, tail in bones:\n    b = data.edit_bones.new("mixamorig:" + name)\n    b.head, b.tail = head, tail\n    if parent:\n        b.parent = data.edit_bones["mixamorig:" + parent]\n        b.use_connect = tuple(b.parent.tail) == tuple(b.head)\nbpy.ops.object.mode_set(mode="POSE")\n\ndef ease(t, a, b):\n    u = min(max((t - a) / (b - a), 0.0), 1.0)\n    return u * u * (3 - 2 * u)\n\ndef rot(axis, deg):\n    return Matrix.Rotation(math.radians(deg), 3, axis)\n\ndef pose(name, w):  # a rotation in world axes, relative to the parent\'s\n    pb = arm.pose.bones["mixamorig:" + name]\n    rest = pb.bone.matrix_local.to_3x3()\n    pb.rotation_mode = "QUATERNION"\n    pb.rotation_quaternion = (rest.inverted() @ w @ rest).to_quaternion()\n    pb.keyframe_insert("rotation_quaternion")\n\nrecord = {"fps": fps, "frames": []}\nfor f in range(1, n + 1):\n    scene.frame_set(f)\n    t = (f - 1) / fps\n    up = ease(t, 0.5, 0.9) - 0.6 * ease(t, 1.4, 2.0)\n    drift = 0.5 * math.sin(2 * math.pi * t / 2.0)\n    pose("Spine1", rot("X", 6 * drift) @ rot("Y", 3 * drift))\n    pose("Neck", rot("Z", 10 * drift))\n    pose("LeftArm", rot("Z", -25 * drift) @ rot("Y", 80 - 20 * drift))\n    pose("LeftForeArm", rot("Z", -30 - 20 * drift))\n    pose("RightArm", rot("Z", 60 * up) @ rot("Y", -80 + 110 * up))\n    pose("RightForeArm", rot("Z", 25 + 50 * up) @ rot("X", 20 * up))\n    for name in ("Hips", "Spine", "Spine1", "Spine2", "Neck", "Head", "LeftShoulder", "RightShoulder", "LeftHand", "RightHand"):\n        if name not in ("Spine1", "Neck"):\n            pb = arm.pose.bones["mixamorig:" + name]\n            pb.rotation_mode = "QUATERNION"\n            pb.keyframe_insert("rotation_quaternion")\nfor f in range(1, n + 1):\n    scene.frame_set(f)\n    bpy.context.view_layer.update()\n    record["frames"].append({pb.name.split(":")[1]: [list(arm.matrix_world @ pb.head), list(arm.matrix_world @ pb.tail)]\n                             for pb in arm.pose.bones})\njson.dump(record, open(out_json, "w"))\nbpy.ops.object.mode_set(mode="OBJECT")\narm.select_set(True)\nbpy.ops.export_anim.bvh(filepath=out_bvh, frame_start=1, frame_end=n)\nbpy.ops.export_scene.gltf(filepath=out_glb, export_format="GLB", export_animations=True, export_frame_range=True,\n                          export_force_sampling=True)\nprint("DONE")\n'


@pytest.mark.skipif(shutil.which("blender") is None, reason="blender is not installed")
def test_takes_written_by_blender(tmp_path, capsys):
    import json

    # Blender takes its Python's prefix from the python3 on PATH: give it the system's
    r = subprocess.run([shutil.which("blender"), "-b", "--factory-startup", "--python-expr", BLENDER_RIG, "--",
                        str(tmp_path / "b.bvh"), str(tmp_path / "b.glb"), str(tmp_path / "b.json"), "30"],
                       capture_output=True, text=True, timeout=120, check=False,
                       env={"PATH": "/usr/bin:/bin", "HOME": pwd.getpwuid(os.getuid()).pw_dir})
    assert r.returncode == 0 and "DONE" in r.stdout, r.stdout + r.stderr
    frames = json.loads((tmp_path / "b.json").read_text())["frames"]
    names = {"left_elbow": "LeftArm", "left_wrist": "LeftForeArm", "right_elbow": "RightArm",
             "right_wrist": "RightForeArm"}
    for source in ("b.bvh", "b.glb"):
        code, out, err = _run(capsys, "library", "add", "blended", "--from", tmp_path / source,
                              "--frames", "0:60", "--to", tmp_path / "lib", "--force")
        assert code == 0, err
        assert "at 15 fps from frames 0:60 at 30 fps" in out
        stroke = _source_stroke(out)
        assert abs(stroke / 30 - 0.9) <= 0.1, out
        want = {}
        for bone, name in names.items():
            head, tail = (np.asarray(p) for p in frames[stroke][name])
            x, y, z = tail - head
            want[bone] = np.array([x, z, -y])  # Blender's axes (z up, facing -y) -> sgt's
        errors = _stroke_errors(tmp_path / "lib", "blended", want)
        assert max(errors.values()) < 3.0, (source, errors)
        assert len(load_library([tmp_path / "lib"], use_config=False).get("blended").clip().poses) == 30


# -- glTF: bad files ------------------------------------------------------------------------

def _gltf(**extra) -> dict:
    doc = {"asset": {"version": "2.0"}, "nodes": [{"name": "Hips", "children": [1]}, {"name": "Spine"}],
           "animations": [{"samplers": [{"input": 0, "output": 1}],
                           "channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}}]}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "type": "SCALAR", "count": 2},
                         {"bufferView": 1, "componentType": 5126, "type": "VEC4", "count": 2}],
           "bufferViews": [{"buffer": 0, "byteLength": 8}, {"buffer": 0, "byteOffset": 8, "byteLength": 32}],
           "buffers": [{"byteLength": 40, "uri": "data:application/octet-stream;base64,"
                        + __import__("base64").b64encode(np.array([0, 1 / 30, 0, 0, 0, 1, 0, 0, 0, 1],
                                                                  dtype="<f4").tobytes()).decode()}]}
    doc.update(extra)
    return doc


@pytest.mark.parametrize("change,words", [
    ({}, ["no joint for", "--map"]),
    ({"buffers": [{"byteLength": 40, "uri": "../outside.bin"}]}, ["buffers[0]"]),
    ({"buffers": [{"byteLength": 4000, "uri": "data:application/octet-stream;base64,AAAA"}]}, ["4000 bytes"]),
    ({"nodes": [{"name": "Hips", "children": [1]}, {"name": "Spine", "children": [0]}]}, ["trees"]),
    ({"accessors": [{"bufferView": 0, "componentType": 5126, "type": "SCALAR", "count": 2000000},
                    {"bufferView": 1, "componentType": 5126, "type": "VEC4", "count": 2}]}, ["accessors[0]"]),
    ({"asset": {"version": "1.0"}}, ["glTF version"]),
])
def test_bad_gltf_files(tmp_path, capsys, change, words):
    (tmp_path / "outside.bin").write_bytes(bytes(40))
    folder = tmp_path / "take"
    folder.mkdir()
    take = folder / "t.gltf"
    take.write_text(__import__("json").dumps(_gltf(**change)))
    code, _, err = _run(capsys, "library", "add", "x", "--from", take, "--frames", "0:2", "--to", tmp_path / "lib")
    assert code == 1 and len(err.strip().splitlines()) == 1 and "Traceback" not in err and "t.gltf" in err
    assert all(w in err for w in words), err


def test_a_truncated_glb(tmp_path, capsys):
    take = tmp_path / "t.glb"
    take.write_bytes(b"glTF" + (2).to_bytes(4, "little") + (400).to_bytes(4, "little")
                     + (300).to_bytes(4, "little") + b"JSON" + b"{}")
    code, _, err = _run(capsys, "library", "add", "x", "--from", take, "--frames", "0:2", "--to", tmp_path / "lib")
    assert code == 1 and "t.glb" in err and "runs past the end" in err


# -- the project's own exports ----------------------------------------------------------------

@pytest.mark.parametrize("rig", ["sgt", "mixamo", "smplx"])
def test_the_projects_own_bvh_exports_come_back(tmp_path, capsys, rig):
    """`sgt export` BVH on sgt's rig, Mixamo's and SMPL-X's: every frame's arms come back
    (on sgt's own rig every bone)."""
    from core.motion import MotionClip
    from renders.export import write_bvh as export_bvh
    from renders.rigs import get_rig

    poses = load_library(use_config=False).get("point_up").clip().poses
    export_bvh(tmp_path / "out.bvh", MotionClip(poses=poses), get_rig(rig))
    code, _, err = _run(capsys, "library", "add", "back", "--from", tmp_path / "out.bvh",
                          "--frames", f"0:{len(poses)}", "--to", tmp_path / "lib")
    assert code == 0, err
    got = load_library([tmp_path / "lib"], use_config=False).get("back").clip().poses
    assert got.shape == poses.shape
    bones = list(BONE_INDEX) if rig == "sgt" else list(ARMS)
    g = got.reshape(len(got), -1, 3)[:, [BONE_INDEX[b] for b in bones]]
    w = poses.reshape(len(poses), -1, 3)[:, [BONE_INDEX[b] for b in bones]]
    cos = np.sum(g * w, axis=-1) / np.linalg.norm(g, axis=-1) / np.linalg.norm(w, axis=-1)
    assert np.degrees(np.arccos(np.clip(cos, -1, 1))).max() < 3.0

"""`sgt edit`'s pose mode in a real terminal (tmux; the pattern of tests/test_editor_tmux.py): a gesture of
three keyframes is posed with the keys, saved into the script's @library folder, inserted before a word,
and the script saved; the saved file reads back through `sgt library show` exactly, holds the poses the
keys make by core/ik.py in the preview's screen axes, and the take generated from the script has the
stroke on the arm within 1 degree at the skeleton's bone lengths; `sgt check` and `sgt fmt --check` pass.

Set SGT_EDIT_SCREENS=FOLDER to keep the screen's text (docs/editor-pose.txt comes from it).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from test_editor_tmux import Tmux

from core import ik
from core.motion import load_motion_file
from core.skeleton import BONE_LENGTHS, BONES, JOINT_INDEX, positions_from_pose
from library.posing import new_draft
from renders.clips import track_clip
from renders.terminal import project
from sgt_tui.editor.posing import STEP

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = "@library gestures\n@seed 4\n\nguide: Look at the shelf over there, by the lifts.\n"
NAME = "reach_tmux"
SCREENS = os.environ.get("SGT_EDIT_SCREENS")


def sgt(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sgt_tui", *args], check=False, cwd=ROOT, capture_output=True, text=True,
                          timeout=300)


def keyed(pose, moves: list[tuple[int, int]]) -> np.ndarray:
    """What the arrow keys make of ``pose`` with the right wrist selected: one IK solve per key."""
    # the preview's screen axes, from the projection it draws with: the directions that move a point right and up on it
    right = np.array([project(np.eye(3)[i][None])[0, 0] for i in range(3)])
    up = np.array([project(np.eye(3)[i][None])[0, 1] for i in range(3)])
    for dx, dy in moves:
        wrist = positions_from_pose(pose)[JOINT_INDEX["right_wrist"]]
        pose = ik.solve_arm(pose, "right", wrist + STEP * (dx * right + dy * up))
    return pose


@contextlib.contextmanager
def editing(tmp_path: Path, script: Path):
    """`sgt edit SCRIPT` in its own tmux server, once it shows its engine; the server stopped after."""
    tmux = Tmux(tmp_path)
    try:
        tmux.start(script)
        tmux.wait_for("engine rules")
        yield tmux
    finally:
        tmux.close()


def _angle(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return math.degrees(math.acos(max(-1.0, min(1.0, float(a @ b / np.linalg.norm(a) / np.linalg.norm(b))))))


def test_a_gesture_posed_with_the_keys_is_saved_inserted_and_generated(tmp_path):
    folder = tmp_path / "work"
    (folder / "gestures").mkdir(parents=True)
    script = folder / "talk.sgt"
    script.write_text(SCRIPT)
    with editing(tmp_path, script) as tmux:
        tmux.keys("C-l")
        tmux.wait_for("Go to")
        tmux.keys("4", "Enter")
        tmux.keys(*["Right"] * 20)  # in "shelf"
        tmux.keys("F12")
        tmux.wait_for("Pose ·")
        tmux.wait_for("keyframe 2/3")  # the stroke, the right wrist selected
        tmux.wait_for("joint: right wrist")
        tmux.keys(*["Up"] * 14)
        tmux.keys(*["Left"] * 3)
        tmux.keys("z")  # undo the last, then redo it
        tmux.keys("y")
        tmux.keys("h")  # the right hand: the next shape (open)
        tmux.wait_for("right hand open")
        tmux.keys(",")  # the first keyframe: the preparation
        tmux.wait_for("keyframe 1/3")
        tmux.keys("l")
        tmux.wait_for("Label")
        tmux.keys(*["BSpace"] * 8)
        tmux.keys("prepare", literal=True)
        tmux.keys("Enter")
        tmux.wait_for("· prepare")
        tmux.keys(*["Up"] * 5)
        tmux.keys(".")
        tmux.wait_for("keyframe 2/3")
        if SCREENS:
            Path(SCREENS).mkdir(parents=True, exist_ok=True)
            (Path(SCREENS) / "editor-pose.txt").write_text(tmux.screen())
        tmux.keys("w")
        tmux.wait_for("Save as gesture")
        tmux.keys(*["BSpace"] * 12)
        tmux.keys(NAME, literal=True)
        tmux.keys("Enter")
        tmux.wait_for(f"saved gestures/{NAME}.toml")
        tmux.keys("Enter")  # [pose:reach_tmux] at the cursor
        tmux.wait_gone("Pose ·")
        tmux.keys("C-s")
        tmux.wait_for("talk.sgt │ ok")
        assert script.read_text() == SCRIPT.replace("the shelf", f"the [pose:{NAME}] shelf")
        tmux.keys("C-q")

    path = folder / "gestures" / f"{NAME}.toml"
    spec = tomllib.loads(path.read_text())
    shown = sgt("library", "show", NAME, "--dir", str(folder / "gestures"), "--json")
    assert shown.returncode == 0, shown.stderr
    shown = json.loads(shown.stdout)
    assert [k["label"] for k in shown["keyframes"]] == [k.get("label") for k in spec["keyframes"]] == ["prepare", "stroke", "retract"]
    assert [k["stroke"] for k in shown["keyframes"]] == [False, True, False] and shown["drives"] == ["right_arm"]
    for k_shown, k_file in zip(shown["keyframes"], spec["keyframes"]):
        for bone in ("right_elbow", "right_wrist"):
            if bone in k_file:
                assert k_shown["bones"][bone] == k_file[bone]  # every digit
    assert spec["keyframes"][1]["right_hand"] == "open"

    # the keys moved the wrist in the preview's axes by core/ik.py: 14 up, 3 left (the stroke); 5 up (the preparation)
    rest = new_draft("x").keys[0].pose
    names = [c for _, c in BONES]
    for i, moves in ((0, [(0, 1)] * 5), (1, [(0, 1)] * 14 + [(-1, 0)] * 3)):
        expected = keyed(rest, moves).reshape(9, 3)
        for bone in ("right_elbow", "right_wrist"):
            assert np.abs(np.asarray(spec["keyframes"][i][bone]) - expected[names.index(bone)]).max() < 1e-12

    # the take: the stroke on the arm, at the bone lengths
    assert sgt("generate", str(script), "-o", str(folder / "take.json")).returncode == 0
    motion = load_motion_file(folder / "take.json")
    clip = track_clip(motion.tracks[0], motion.clips)
    control = next(c for c in clip.controls if c.name == NAME)
    positions = clip.positions[control.stroke_frame].astype(np.float64)
    stroke = np.asarray([spec["keyframes"][1][b] for b in ("right_elbow", "right_wrist")])
    for bone, want in zip(("right_elbow", "right_wrist"), stroke):
        parent = {c: p for p, c in BONES}[bone]
        got = positions[JOINT_INDEX[bone]] - positions[JOINT_INDEX[parent]]
        assert _angle(got, want) < 1.0, (bone, _angle(got, want))
    for p, c in BONES:
        assert abs(np.linalg.norm(positions[JOINT_INDEX[c]] - positions[JOINT_INDEX[p]]) - BONE_LENGTHS[c]) < 1e-4
    checked = sgt("check", str(script))
    assert checked.returncode == 0, checked.stdout + checked.stderr
    formatted = sgt("fmt", "--check", str(script))
    assert formatted.returncode == 0, formatted.stdout + formatted.stderr


def test_the_pose_mode_saves_only_into_a_gesture_folder_and_inserts_only_a_saved_gesture(tmp_path):
    script = tmp_path / "plain.sgt"
    script.write_text("guide: Look at the shelf.\n")
    with editing(tmp_path, script) as tmux:
        tmux.keys("F12")
        tmux.wait_for("Pose ·")
        tmux.keys("Up", "Up")
        tmux.keys("w")
        tmux.wait_for("no @library folder")
        tmux.keys("Enter")  # not saved: nothing to insert
        tmux.wait_for("save the gesture first")
        tmux.keys("Escape")
        tmux.wait_gone("Pose ·")
    assert script.read_text() == "guide: Look at the shelf.\n"
    assert sorted(p.name for p in tmp_path.iterdir() if p.suffix == ".toml") == []

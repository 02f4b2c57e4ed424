"""Tests of `sgt library list|show|add`, called through sgt_tui.cli.main."""

from __future__ import annotations

import json

import numpy as np
import pytest

from core.motion import MotionClip, save_motion
from core.skeleton import N_BONES
from library import load_library
from sgt_tui import cli


@pytest.fixture(autouse=True)
def _env(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.delenv("XDG_CONFIG_HOME", raising=False)
    monkeypatch.delenv("SGT_LIBRARY_PATH", raising=False)
    monkeypatch.chdir(tmp_path)


def _run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_list(capsys):
    code, out, err = _run(capsys, "library", "list")
    assert code == 0
    names = load_library(use_config=False).names()
    for n in names:
        assert f"\n{n} " in out
    assert f"{len(names)} gestures" in out
    assert max(len(line) for line in out.splitlines()) <= 80
    assert "problem" not in out


def test_list_tag_and_json(capsys):
    code, out, _ = _run(capsys, "library", "list", "--tag", "deictic", "--json")
    assert code == 0
    doc = json.loads(out)
    names = {g["name"] for g in doc["gestures"]}
    assert {"point_left", "point_right", "point_self"} <= names
    assert "wave" not in names
    assert all("deictic" in g["tags"] and g["origin"] == "built-in" for g in doc["gestures"])


def test_list_override_and_problems(tmp_path, capsys):
    user = tmp_path / "mine"
    user.mkdir()
    (user / "nod.toml").write_text(
        'name = "nod"\nduration = 1\n[[keyframes]]\ntime = 0\nstroke = true\n')
    (user / "bad.toml").write_text('name = "bad"\n')
    code, out, _ = _run(capsys, "library", "list", "--dir", str(user))
    assert code == 0
    nod_line = next(line for line in out.splitlines() if line.startswith("nod "))
    assert str(user) in nod_line and "overrides" in nod_line
    assert "1 problem" in out and "bad.toml" in out and "duration" in out


def test_show(capsys):
    code, out, _ = _run(capsys, "library", "show", "point_right")
    assert code == 0
    g = load_library(use_config=False).get("point_right")
    assert g.description.split()[0] in out
    assert f"{len(g.clip().poses)} frames" in out
    assert f"frame {g.clip().stroke_frame}" in out
    assert "right_elbow" in out
    assert max(len(line) for line in out.splitlines()) <= 80
    code, out2, _ = _run(capsys, "library", "show", "point_right", "--speed", "2", "--json")
    doc = json.loads(out2)
    assert doc["frames"] == len(g.clip(speed=2).poses)
    assert doc["stroke_frame"] == g.clip(speed=2).stroke_frame
    assert len(doc["keyframes"]) == len(g.keyframes)


def test_show_flip_lists_the_mirrored_keyframes(capsys):
    g = load_library(use_config=False).get("point_right")
    code, out, _ = _run(capsys, "library", "show", "point_right", "--flip", "--json")
    assert code == 0
    doc = json.loads(out)
    assert doc["flip"] and doc["drives"] == ["left_arm"]
    flipped = g.clip(flip=True)
    for k, shown in zip(g.keyframes, doc["keyframes"]):
        assert not any(b.startswith("right_") for b in shown["bones"])
        for bone, v in k.bones.items():
            mirrored = shown["bones"]["left_" + bone[len("right_"):]]
            assert mirrored == ("rest" if v is None else [-v[0], v[1], v[2]])
            if v is not None:  # what is listed is what the flipped clip plays on that frame
                i = ["neck", "nose", "head_top", "left_shoulder", "left_elbow", "left_wrist"].index(
                    "left_" + bone[len("right_"):])
                assert np.allclose(flipped.poses[shown["frame"]].reshape(N_BONES, 3)[i], mirrored, atol=1e-4)
        assert all(h.startswith("left_") for h in shown["hands"])
        assert shown["hands"] == {"left_" + h[len("right_"):]: v for h, v in k.hands.items()}
    code, text, _ = _run(capsys, "library", "show", "point_right", "--flip")
    assert "mirrored" in text and "left_elbow [0.951, -0.211, 0.224]" in text and "right_elbow" not in text
    assert "left_hand point" in text and "right_hand" not in text


def test_show_unknown_is_a_usage_error(capsys):
    """A name that matches nothing is a usage error (2), like `--utterance 50`."""
    code, out, err = _run(capsys, "library", "show", "point_rigth")
    assert code == 2
    assert "point_right" in err and "Traceback" not in err


def test_no_subcommand_is_usage_error(capsys):
    code, _, err = _run(capsys, "library")
    assert code == 2


def _motion(tmp_path, name="rec.json"):
    lib = load_library(use_config=False)
    a = lib.get("wave").clip().poses
    b = lib.get("point_left").clip(flip=True).poses
    path = tmp_path / name
    save_motion(path, [MotionClip(poses=np.concatenate([a, b])), MotionClip(poses=b)])
    return path, np.concatenate([a, b])


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_add_round_trip(tmp_path, capsys, suffix):
    path, poses = _motion(tmp_path, "rec" + suffix)
    a, b = 5, 40
    code, out, err = _run(capsys, "library", "add", "my_wave", "--from", str(path),
                          "--frames", f"{a}:{b}", "--to", str(tmp_path / "lib"),
                          "--tags", "greeting, test", "--description", "mine")
    assert code == 0, err
    target = tmp_path / "lib" / "my_wave.toml"
    assert target.exists() and str(target) in out
    lib = load_library([tmp_path / "lib"], use_config=False)
    assert lib.problems == []
    g = lib.get("my_wave")
    assert g.tags == ["greeting", "test"] and g.description == "mine"
    got = g.clip().poses.reshape(-1, N_BONES, 3).astype(np.float64)
    want = poses[a:b].reshape(-1, N_BONES, 3).astype(np.float64)
    assert got.shape == want.shape
    err_deg = np.degrees(np.arccos(np.clip(np.sum(got * want, axis=-1), -1, 1)))
    assert err_deg.max() < 3.0
    assert len(g.keyframes) < (b - a)  # it really chose keyframes
    assert g.clip().stroke_frame is not None


def test_add_keeps_any_description_and_tags_exactly(tmp_path, capsys):
    """Text written into the spec file reads back unchanged: quotes, backslashes, newlines,
    tabs and every other control character are escaped (tomllib refuses them raw)."""
    import tomllib

    from library.extract import spec_text_from_poses

    path, poses = _motion(tmp_path)
    description = 'say "hi"\tthen\nwave \\o/ \x01\x7f\r\x08\x0c ünï'
    code, out, err = _run(capsys, "library", "add", "odd", "--from", str(path), "--frames", "5:30",
                          "--to", str(tmp_path / "lib"), "--description", description, "--tags", 'a"b, c\\d')
    assert code == 0, err
    lib = load_library([tmp_path / "lib"], use_config=False)
    assert lib.problems == [] and lib.get("odd").description == description
    assert lib.get("odd").tags == ['a"b', "c\\d"]
    every = "".join(chr(c) for c in range(0x20)) + "\x7f\\\""
    text, _ = spec_text_from_poses("every", poses[:20], description=every, tags=[every])
    data = tomllib.loads(text)
    assert data["description"] == every and data["tags"] == [every]


def test_add_refuses_overwrite_and_bad_ranges(tmp_path, capsys):
    path, poses = _motion(tmp_path)
    args = ["library", "add", "span", "--from", str(path), "--to", str(tmp_path / "lib")]
    assert _run(capsys, *args, "--frames", "0:10")[0] == 0
    code, _, err = _run(capsys, *args, "--frames", "0:12")
    assert code == 2 and "--force" in err
    assert _run(capsys, *args, "--frames", "0:12", "--force")[0] == 0
    assert len(load_library([tmp_path / "lib"], use_config=False).get("span").clip().poses) == 12
    code, _, err = _run(capsys, *args, "--frames", "10:5000", "--force")
    assert code == 2 and str(len(poses)) in err
    code, _, err = _run(capsys, *args, "--frames", "7:7", "--force")
    assert code == 2 and "at least 2" in err
    code, _, err = _run(capsys, *args, "--frames", "abc", "--force")
    assert code == 2 and "A:B" in err
    code, _, err = _run(capsys, *args, "--frames", "0:5", "--utterance", "7", "--force")
    assert code == 2 and "utterance 7" in err
    code, _, err = _run(capsys, "library", "add", "x", "--from", str(tmp_path / "none.json"),
                        "--frames", "0:5")
    assert code == 1 and "no such file" in err  # a missing input: the input's problem
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    code, _, err = _run(capsys, "library", "add", "x", "--from", str(bad), "--frames", "0:5", "--to", str(tmp_path / "lib"))
    assert code == 1 and "bad.json" in err  # a file that exists but is not a motion file: the input's problem


def test_add_default_folder(tmp_path, capsys, monkeypatch):
    path, _ = _motion(tmp_path)
    assert _run(capsys, "library", "add", "here", "--from", str(path), "--frames", "0:8")[0] == 0
    assert (tmp_path / "gestures" / "here.toml").exists()
    monkeypatch.setenv("SGT_LIBRARY_PATH", str(tmp_path / "cfg"))
    assert _run(capsys, "library", "add", "there", "--from", str(path), "--frames", "0:8")[0] == 0
    assert (tmp_path / "cfg" / "there.toml").exists()


@pytest.mark.parametrize("module", ["sgt_tui", "sgt_tui.cli"])
def test_python_m_usage_error_is_a_message_not_a_traceback(tmp_path, module):
    """`python -m` runs the CLI as __main__; a usage error must still exit 2 with one line."""
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", module, "export", str(tmp_path / "none.json"), "-o", "x.xyz"],
                       capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr and "sgt export: error:" in r.stderr


def test_add_keeps_any_text_in_tags_and_description(tmp_path, capsys):
    """Control characters, quotes and backslashes are escaped in the spec (they made invalid TOML)."""
    path, _ = _motion(tmp_path)
    odd = 'a\x08b "q" back\\slash del\x7f tab\t'
    code, _, err = _run(capsys, "library", "add", "odd", "--from", str(path), "--frames", "0:8",
                        "--to", str(tmp_path / "lib"), "--tags", odd + ",x", "--description", odd)
    assert code == 0, err
    lib = load_library([tmp_path / "lib"], use_config=False)
    assert lib.problems == []
    g = lib.get("odd")
    assert g.tags == [odd.strip(), "x"] and g.description == odd


def test_add_refuses_text_that_is_not_utf8(tmp_path, capsys):
    """Bytes that are not UTF-8 on the command line (kept by Python as lone surrogates)."""
    path, _ = _motion(tmp_path)
    code, _, err = _run(capsys, "library", "add", "odd", "--from", str(path), "--frames", "0:8",
                        "--to", str(tmp_path / "lib"), "--tags", "caf\udce9")
    assert code == 2 and "--tags must be UTF-8" in err
    assert not (tmp_path / "lib" / "odd.toml").exists()


def test_sheet_views_face_the_camera_and_show_the_side():
    """The sheet's default views (renders.library_sheet.VIEWS) are the mannequin's front and
    side cameras: the character (facing +z) faces the front camera, and in the side view it
    faces the right of the picture."""
    from renders.library_sheet import VIEWS
    from renders.mannequin import TARGET, camera_pose

    assert VIEWS == ("front", "side")
    facing = np.array([0.0, 0.0, 1.0])
    front, side = camera_pose("front"), camera_pose("side")
    to_camera = (front[:3, 3] - TARGET) * [1, 0, 1]
    assert np.allclose(to_camera / np.linalg.norm(to_camera), facing, atol=1e-9)  # faces the camera
    to_camera = (side[:3, 3] - TARGET) * [1, 0, 1]
    assert abs(to_camera @ facing) < 1e-9 and facing @ side[:3, 0] > 0.99  # in profile, facing screen right


def test_sheet_draws_each_gesture_front_and_side(tmp_path, capsys):
    from PIL import Image

    out = tmp_path / "sheet.png"
    code, _, err = _run(capsys, "library", "sheet", "point_right", "nod", "-o", str(out), "--columns", "2")
    assert code == 0, err
    assert "2 gestures" in err
    img = np.asarray(Image.open(out).convert("RGB")).astype(int)
    assert img.shape[1] == 2 * 2 * 150 and img.shape[0] > 150
    # the four views of the two strokes all differ: front and side of each, and the two gestures
    views = [img[:150, i * 150 : (i + 1) * 150] for i in range(4)]
    for i in range(4):
        for j in range(i + 1, 4):
            assert np.abs(views[i] - views[j]).mean() > 1.0, (i, j)


@pytest.mark.parametrize("argv", [["sheet", "no_such", "-o", "x.png"], ["sheet", "-o", "x.gif"],
                                  ["sheet", "--tag", "no_such_tag", "-o", "x.png"], ["sheet", "--columns", "0", "-o", "x.png"]])
def test_sheet_usage_errors(tmp_path, capsys, argv):
    code, _, err = _run(capsys, "library", *argv)
    assert code == 2 and "Traceback" not in err
    assert not (tmp_path / "x.png").exists()


def test_add_keeps_the_hands_by_name(tmp_path, capsys):
    """A recorded span's hands come back as the nearest shape and palm at its keyframes."""
    from core.hands import SIDES, concat, nearest_palm, nearest_shape

    lib = load_library(use_config=False)
    clips = [lib.get("thumbs_up").clip(), lib.get("wave").clip()]
    path = tmp_path / "rec.json"
    save_motion(path, [MotionClip(poses=np.concatenate([c.poses for c in clips]), hands=concat([c.hands for c in clips]))])
    n0 = clips[0].n_frames
    for name, a, b, shape, palm in (("my_thumb", 0, n0, "thumb_up", "in"), ("my_wave", n0, n0 + clips[1].n_frames, "open", "forward")):
        code, _, err = _run(capsys, "library", "add", name, "--from", str(path), "--frames", f"{a}:{b}",
                            "--to", str(tmp_path / "lib"))
        assert code == 0, err
        g = load_library([tmp_path / "lib"], use_config=False).get(name)
        named = [k.hands for k in g.keyframes if k.hands]
        assert any(h.get("right_hand") == shape for h in named)
        r = SIDES.index("right")
        clip = g.clip()
        assert nearest_shape(clip.hands.fingers[clip.stroke_frame, r]) == shape
        assert nearest_palm(clip.hands.palm[clip.stroke_frame, r], "right") == palm
    code, out, _ = _run(capsys, "library", "show", "thumbs_up")
    assert code == 0 and "right_hand thumb_up" in out


def _back_of_the_hips(image, row) -> int:
    """The leftmost figure pixel of ``row`` in a side view (the character faces right): its back."""
    from renders.mannequin import BACKGROUND

    figure = np.abs(image[row].astype(int) - BACKGROUND).sum(axis=-1) > 30
    return int(np.argmax(figure))


def test_sheet_lean_bends_at_the_waist_not_the_chest():
    """From the side, lean_forward and lean_back tilt the torso over hips that stay where they
    are (the skeleton's root, the spine joint at 1 m, is the waist). The hips used to turn with
    the torso, so their back swung out as the chest went forward, and the lean seemed to pivot
    at the chest: the back of the hips moved 4-5 pixels at 400 (2 cm), while the neck moved 36."""
    from renders.library_sheet import stroke_views
    from renders.mannequin import Mannequin, project

    size = 400
    row = round(float(project(np.array([0.0, 0.9, 0.0]), size, size, "side")[1]))  # through the hips
    lib = load_library(use_config=False)
    with Mannequin(size, size) as m:
        rest = stroke_views(m, lib.get("nod").clip(), ("side",))[0]  # a stroke that leaves the torso upright
        back = _back_of_the_hips(rest, row)
        for name in ("lean_forward", "lean_back", "bow"):
            image = stroke_views(m, lib.get(name).clip(), ("side",))[0]
            assert abs(_back_of_the_hips(image, row) - back) <= 2, name
            top = np.argmax((np.abs(image.astype(int) - rest.astype(int)).sum(axis=-1) > 30).any(axis=1))
            assert top < row - 100, name  # while the chest and head do move


def test_list_shows_every_tag_whole(tmp_path, capsys):
    """A long list of tags goes on, under the column, on lines of its own: no tag is cut."""
    user = tmp_path / "mine"
    user.mkdir()
    tags = ["greeting", "friendly", "both-hands", "open", "welcoming-the-visitor-at-the-door", "loud"]
    (user / "hello_all.toml").write_text(
        f'name = "hello_all"\nduration = 1\ntags = {json.dumps(tags)}\n[[keyframes]]\ntime = 0\nstroke = true\n')
    code, out, _ = _run(capsys, "library", "list", "--dir", str(user))
    assert code == 0
    lines = out.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("hello_all "))
    header = next(line for line in lines if line.startswith("NAME "))
    tags_at, from_at = header.index("TAGS"), header.index("FROM")
    more = [x for x in lines[at + 1:at + 6] if x.startswith(" ")]
    column = [lines[at][tags_at:from_at]] + [x[tags_at:] for x in more]
    assert [t.strip() for t in ",".join(column).split(",") if t.strip()] == tags
    assert lines[at][from_at:].startswith(str(user)) and "..." not in "\n".join(column)
    assert max(len(line) for line in lines) <= 80 + len(str(user))

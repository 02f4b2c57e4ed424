"""Offscreen rendering: GIF timing and loop, overlays, contact sheet, comparison, CLI errors."""

from __future__ import annotations

import numpy as np
import pytest

from core.controls import Control
from core.motion import MotionClip, save_motion
from core.skeleton import FPS
from core.words import TimedWord
from library import load_library

SIZE = (96, 96)
WORDS = [TimedWord("hello", 0.0, 0.6), TimedWord("world", 0.8, 1.6)]
CONTROLS = [Control("pose", "wave", 2, 8), Control("style", "speed", 14, 22)]


def _clip(name: str = "wave", **kw) -> MotionClip:
    from library import load_library

    poses = load_library(use_config=False).get(name).clip().poses
    return MotionClip(poses=poses, words=kw.get("words", WORDS), controls=kw.get("controls", CONTROLS),
                      speaker="guide", text="hello world")


@pytest.fixture(scope="module")
def mannequin():
    from renders.gl import RenderSetupError
    from renders.mannequin import Mannequin

    try:
        m = Mannequin(*SIZE)
    except RenderSetupError as exc:  # pragma: no cover - machines without EGL/OSMesa
        pytest.skip(f"no offscreen GL: {exc}")
    yield m
    m.close()


@pytest.fixture(scope="module")
def clip():
    return _clip()


@pytest.fixture(scope="module")
def gif(tmp_path_factory, mannequin, clip):
    from renders.animate import render_gif

    path = tmp_path_factory.mktemp("gif") / "take.gif"
    info = render_gif(clip, path, size=SIZE, mannequin=mannequin)
    return path, info


def _frames(path):
    from PIL import Image

    im = Image.open(path)
    out, durations = [], []
    for i in range(im.n_frames):
        im.seek(i)
        durations.append(im.info["duration"])
        out.append(np.asarray(im.convert("RGB")).astype(int))
    return im, out, durations


# -- timing ----------------------------------------------------------------------------------

def test_delays_alternate_and_sum_exactly():
    from renders.gifwriter import frame_delays_cs

    assert frame_delays_cs(3) == [7, 6, 7]
    assert sum(frame_delays_cs(15)) == 100
    assert sum(frame_delays_cs(150)) == 1000
    for n in range(1, 50):
        d = frame_delays_cs(n)
        assert set(d) <= {6, 7}
        assert abs(sum(d) * 10 - n * 1000 / FPS) <= 5  # nearest 10 ms: exact when 3 | n


def test_gif_frame_count_duration_and_loop(gif, clip):
    path, info = gif
    im, frames, durations = _frames(path)
    assert im.n_frames == clip.n_frames == info["frames"]
    assert im.size == SIZE
    assert im.info.get("loop") == 0
    assert set(durations) <= {60, 70}
    assert sum(durations) == round(clip.n_frames * 100 / FPS) * 10
    if clip.n_frames % 3 == 0:
        assert sum(durations) == clip.n_frames * 1000 // FPS


def test_gif_has_one_global_palette(gif):
    path, _ = gif
    data = path.read_bytes()
    assert data[:6] == b"GIF89a"
    assert data[10] & 0x80  # global colour table present
    # Every image descriptor has the local-colour-table flag clear.
    pos = 13 + 3 * 256
    seen = 0
    while data[pos] != 0x3B:
        if data[pos] == 0x21:
            pos += 2
            while data[pos]:
                pos += data[pos] + 1
            pos += 1
        elif data[pos] == 0x2C:
            assert not data[pos + 9] & 0x80
            pos += 11
            while data[pos]:
                pos += data[pos] + 1
            pos += 1
            seen += 1
        else:  # pragma: no cover
            pytest.fail(f"unexpected byte {data[pos]:#x} at {pos}")
    assert seen == _frames(path)[0].n_frames


def test_identical_frames_are_not_merged(tmp_path, mannequin):
    from PIL import Image

    from renders.animate import render_gif

    still = MotionClip(poses=np.repeat(_clip().poses[:1], 6, axis=0))
    render_gif(still, tmp_path / "still.gif", size=SIZE, mannequin=mannequin)
    assert Image.open(tmp_path / "still.gif").n_frames == 6


# -- overlays --------------------------------------------------------------------------------

def _near(pixel, color, tol=12):
    return all(abs(int(p) - c) <= tol for p, c in zip(pixel, color))


def test_timeline_spans_are_green_and_red(gif, clip):
    from renders.overlay import POSE_GREEN, STYLE_RED, TRACK, timeline_geometry

    _, frames, _ = _frames(gif[0])
    g = timeline_geometry(*SIZE, clip.n_frames)
    img = frames[0]
    pose_y = (g.pose_top + g.pose_bottom - 1) // 2
    style_y = (g.style_top + g.style_bottom - 1) // 2
    assert _near(img[pose_y, round(g.x(5))], POSE_GREEN)
    assert _near(img[style_y, round(g.x(18))], STYLE_RED)
    # Outside the spans the lanes show the bare track.
    assert _near(img[pose_y, round(g.x(18))], TRACK)
    assert _near(img[style_y, round(g.x(5))], TRACK)


def test_playhead_moves(gif, clip):
    from renders.overlay import INK, timeline_geometry

    _, frames, _ = _frames(gif[0])
    g = timeline_geometry(*SIZE, clip.n_frames)
    y = g.pose_top - 1
    for f in (0, clip.n_frames // 2, clip.n_frames - 1):
        assert _near(frames[f][y, round(g.x(f + 0.5))], INK, tol=30)


def test_word_region_changes_with_the_word(gif):
    _, frames, _ = _frames(gif[0])
    band = slice(0, SIZE[1] // 4)
    a = frames[3][band]    # "hello" (0.2 s)
    a2 = frames[6][band]   # "hello" (0.4 s)
    b = frames[18][band]   # "world" (1.2 s)
    assert np.abs(a - b).sum() > 1000
    # Same word: the text band is (almost) the same, only the hand may pass behind it.
    assert np.abs(a - a2).sum() < np.abs(a - b).sum()


def test_word_at():
    from renders.overlay import word_at

    assert word_at(WORDS, 0.3) == "hello"
    assert word_at(WORDS, 0.7) is None
    assert word_at(WORDS, 1.0) == "world"


# -- sheet and comparison --------------------------------------------------------------------

def test_contact_sheet_size(tmp_path, mannequin, clip):
    from PIL import Image

    from renders.animate import SHEET_FRAMES, render_sheet, sheet_layout

    info = render_sheet([clip], tmp_path / "sheet.png", size=SIZE, at="even", mannequin=mannequin)
    lay = sheet_layout(*SIZE, [min(SHEET_FRAMES, clip.n_frames)])
    im = Image.open(tmp_path / "sheet.png")
    assert im.format == "PNG"
    assert im.size == lay["size"] == (info["width"], info["height"])
    assert im.size == (4 * SIZE[0], lay["title"] + lay["band"] + 2 * (SIZE[1] + lay["caption"]))
    assert len(info["frames"]) == 8 and info["frames"] == sorted(info["frames"])


def test_compare_gif_is_twice_as_wide(tmp_path, mannequin, clip):
    from PIL import Image

    from renders.animate import render_gif

    other = _clip("point_right")
    render_gif(clip, tmp_path / "cmp.gif", size=SIZE, compare=other, labels=("A", "B"), mannequin=mannequin)
    im = Image.open(tmp_path / "cmp.gif")
    assert im.size == (2 * SIZE[0], SIZE[1])
    assert im.n_frames == max(clip.n_frames, other.n_frames)
    im.seek(10)
    rgb = np.asarray(im.convert("RGB")).astype(int)
    left, right = rgb[:, : SIZE[0]], rgb[:, SIZE[0]:]
    assert np.abs(left - right).sum() > 0  # two different takes


# -- command line ----------------------------------------------------------------------------

@pytest.fixture
def motion_file(tmp_path):
    path = tmp_path / "take.json"
    short = MotionClip(poses=_clip().poses[:9], words=WORDS, controls=CONTROLS)
    save_motion(path, [short, short])
    return path


def test_cli_render_writes_gif_and_sheet(tmp_path, motion_file, capsys):
    from PIL import Image

    from sgt_tui.cli import main

    out, sheet = tmp_path / "out.gif", tmp_path / "out.png"
    rc = main(["render", str(motion_file), "-o", str(out), "--sheet", str(sheet), "--size", "64x48",
               "--utterance", "1"])
    assert rc == 0, capsys.readouterr().err
    im = Image.open(out)
    assert im.size == (64, 48) and im.n_frames == 9
    assert Image.open(sheet).size[0] == 64  # one pose control: one picture, at its stroke
    rc = main(["render", str(motion_file), "-o", str(out), "--size", "48x48"])
    assert rc == 0
    assert Image.open(out).n_frames == 18  # both utterances, one after another


@pytest.mark.parametrize("argv_tail, code, message", [
    (["--utterance", "5"], 2, "no utterance 5: the motion has 2 (1..2)"),
    (["--utterance", "3"], 2, "no utterance 3: the motion has 2 (1..2)"),
    (["--utterance", "0"], 2, "--utterance: 0: utterances count from 1 (the first is --utterance 1)"),
    (["--utterance", "-1"], 2, "--utterance"),
    (["--size", "big"], 2, "--size"),
    (["--size", "4x4"], 2, "--size"),
])
def test_cli_render_usage_errors(tmp_path, motion_file, capsys, argv_tail, code, message):
    from sgt_tui.cli import main

    rc = main(["render", str(motion_file), "-o", str(tmp_path / "o.gif"), *argv_tail])
    err = capsys.readouterr().err
    assert rc == code
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "o.gif").exists()


def test_cli_render_bad_inputs(tmp_path, motion_file, capsys):
    from sgt_tui.cli import main

    out = str(tmp_path / "o.gif")
    assert main(["render", str(tmp_path / "missing.json"), "-o", out]) == 1  # a missing input: the input's problem
    assert "no such file" in capsys.readouterr().err
    txt = tmp_path / "notes.txt"
    txt.write_text("hello")
    assert main(["render", str(txt), "-o", out]) == 2
    assert "unknown input type" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "something-else"}')
    assert main(["render", str(bad), "-o", out]) == 1
    assert "sgt-motion" in capsys.readouterr().err
    broken = tmp_path / "broken.npz"
    broken.write_bytes(b"not a zip")
    assert main(["render", str(broken), "-o", out]) == 1
    assert "error" in capsys.readouterr().err
    assert main(["render", str(motion_file), "-o", str(tmp_path / "o.png")]) == 2
    assert ".gif" in capsys.readouterr().err
    assert main(["render", str(motion_file), "-o", out, "--compare", str(bad)]) == 1
    assert not (tmp_path / "o.gif").exists()


def test_help_does_not_import_heavy_libraries():
    """`sgt --help` builds every subcommand's parser without GL, torch, librosa, textual, scipy,
    onnxruntime or the service's web stack."""
    import subprocess
    import sys

    code = ("import sys; from sgt_tui.cli import build_parser; build_parser(); "
            "bad = [m for m in ('pyrender', 'OpenGL', 'trimesh', 'PIL', 'torch', 'librosa', 'textual', 'scipy', "
            "'onnxruntime', 'fastapi', 'uvicorn', 'pydantic', 'importlib.metadata') "
            "if m in sys.modules]; "
            "print(bad); sys.exit(1 if bad else 0)")
    from pathlib import Path

    r = subprocess.run([sys.executable, "-c", code], cwd=Path(__file__).resolve().parent.parent,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_version_is_looked_up_when_asked(capsys):
    from importlib.metadata import version

    from sgt_tui.cli import main

    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"sgt {version('sgt')}\n"


def _skin_pixels(image: np.ndarray) -> np.ndarray:
    """Where the mannequin's skin (hands, head) shows: reddish, unlike the blue body and grey ground."""
    img = image.astype(int)
    return (img[..., 0] > img[..., 2] + 40) & (img[..., 0] > 120)


@pytest.mark.parametrize("view", ["front", "three-quarter"])
def test_hands_show_their_shape_at_240(tmp_path, view):
    """At 240x240 an open hand, a fist and a point at the same arm pose differ where the hand is
    (the head's pixels are the same). From the front (the old default camera's angle) the open
    hand covers the most skin and the point more than the fist; from the three-quarter view
    (from above: the raised hand is foreshortened) each pair still differs by many pixels."""
    from core.hands import HandTrack, hand_positions
    from core.skeleton import positions_from_pose
    from renders.gl import RenderSetupError
    from renders.mannequin import Mannequin

    size = 240
    try:
        m = Mannequin(size, size)
    except RenderSetupError as exc:  # pragma: no cover
        pytest.skip(f"no offscreen GL: {exc}")
    try:
        clip = load_library(use_config=False).get("wave").clip()
        pos = positions_from_pose(clip.poses[clip.stroke_frame])[None]
        skin = {}
        images = {}
        for shape in ("open", "fist", "point"):
            track = HandTrack.constant(1, ("relaxed", shape), ("in", "forward"))
            images[shape] = m.render(pos[0], hand_positions(pos, track)[0], view=view)
            skin[shape] = int(_skin_pixels(images[shape]).sum())
        rest = m.render(pos[0], hand_positions(pos, HandTrack.rest(1))[0], view=view)
    finally:
        m.close()
    if view == "front":
        assert skin["open"] > skin["point"] > skin["fist"], skin
        assert skin["open"] - skin["fist"] > 40, skin  # a visible difference, not a few pixels
    for a, b in (("open", "fist"), ("open", "point"), ("point", "fist")):
        changed = np.any(images[a] != images[b], axis=-1)
        assert changed.sum() > 60, (view, a, b, int(changed.sum()))
    assert not np.array_equal(rest, images["open"])  # the default hand is not the open one

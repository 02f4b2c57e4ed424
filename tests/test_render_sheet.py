"""Contact sheets that show the gestures: a labelled picture at every pose control's stroke on
each speaker's track, a row per speaker (wrapped), speakers told apart by tint; `sgt render
--sheet-at/--view` and `sgt library sheet --size/--view`."""

from __future__ import annotations

import numpy as np
import pytest

from core.skeleton import FPS

SIZE = (120, 120)
#: Two speakers, five gestures; the word each mark is on (the word after it).
SCRIPT = ("guide: Welcome! [pose:open_arms] Look at the shelf [pose:point_right x2] over there.\n"
          "robot: [pose:nod] Yes, [pose:point_front] that one, and [pose:shrug] maybe more.\n")
MARKED = {("guide", "open_arms"): "Look", ("guide", "point_right x2"): "over", ("robot", "nod"): "Yes",
          ("robot", "point_front"): "that", ("robot", "shrug"): "maybe"}


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
def take():
    from dsl import compile_text
    from model.generate import generate

    result = compile_text(SCRIPT, timing="estimate")
    assert result.plan is not None
    return generate(result.plan, engine="keyframe")


@pytest.fixture(scope="module")
def tracks(take):
    from renders.clips import track_clip

    return [track_clip(t, take.clips) for t in take.tracks]


@pytest.fixture(scope="module")
def sheet(tmp_path_factory, mannequin, tracks):
    from PIL import Image

    from renders.animate import render_sheet
    from renders.mannequin import speaker_tint

    path = tmp_path_factory.mktemp("sheet") / "sheet.png"
    info = render_sheet(tracks, path, labels=[t.speaker for t in tracks], size=SIZE,
                        tints=[speaker_tint(i) for i in range(len(tracks))], mannequin=mannequin)
    return info, np.asarray(Image.open(path).convert("RGB")).astype(int)


def _expected_strokes(take):
    """(speaker, gesture, frame on the performance clock) of every pose control, from the
    utterances' own clips (not the tracks the sheet draws)."""
    out = []
    for c in take.clips:
        for k in c.controls:
            if k.kind == "pose":
                label = k.name + (f" x{k.options['speed']}" if k.options.get("speed", 1) != 1 else "")
                out.append((c.speaker, label, c.start_frame + k.stroke_frame))
    return sorted(out)


def test_a_labelled_picture_at_every_stroke_of_every_speaker(take, tracks, sheet, mannequin):
    from core.hands import hand_positions

    info, img = sheet
    panels = info["panels"]
    assert sorted((p.label, p.gesture, p.frame) for p in panels) == _expected_strokes(take)
    assert len(panels) == 5 == sum(1 for c in take.clips for k in c.controls if k.kind == "pose")
    assert {(p.label, p.gesture): p.word for p in panels} == MARKED
    # Each picture is the speaker's track at that frame, in the speaker's tint, with the close-up
    # of its face (the part above the timeline, which shows the playhead).
    from PIL import Image

    from renders.animate import label_color
    from renders.face_closeup import FaceInset, inset_side
    from renders.mannequin import DEFAULT_VIEW, FaceFrames, speaker_tint
    from renders.overlay import timeline_geometry

    top = timeline_geometry(*SIZE, 2).top - 12
    inset = FaceInset(inset_side("auto", DEFAULT_VIEW, *SIZE), *SIZE)  # on at this size
    for p in panels:
        track = tracks[p.row]
        hands = hand_positions(track.positions[p.frame : p.frame + 1], track.hands.take(slice(p.frame, p.frame + 1)))
        face = FaceFrames(track.face)[p.frame] if track.face is not None else None  # the face too
        tint = speaker_tint(p.row)
        want = Image.fromarray(mannequin.render(track.positions[p.frame], hands[0], tint=tint, face=face))
        inset.draw(want, mannequin, track.positions[p.frame], hands[0], face, tint, label_color(tint))
        want = np.asarray(want).astype(int)
        x0, y0, x1, y1 = p.box
        # (column 0 of a picture after the first of a line is the line between pictures)
        assert np.abs(img[y0 : y0 + top, x0 + 1 : x1] - want[:top, 1:]).max() <= 2, (p.gesture, p.frame)


def test_the_labels_are_on_the_sheet(sheet):
    """Every caption line (gesture, word, frame) is drawn where the layout says: the crop of the
    sheet matches the same text drawn alone."""
    from PIL import Image, ImageDraw

    from renders import overlay

    info, img = sheet
    for p in info["panels"]:
        texts = [t for t, *_ in p.lines]
        assert texts[0] == p.gesture and texts[1] == f"“{p.word}”"
        assert texts[2] == f"frame {p.frame} · {p.frame / FPS:.2f} s"
        for text, centre, size, bold, fill in p.lines:
            font = overlay.font(size, bold=bold)
            ref = Image.new("RGB", (img.shape[1], img.shape[0]), overlay.WHITE)
            d = ImageDraw.Draw(ref)
            box = d.textbbox(centre, text, font=font, anchor="mm")
            d.text(centre, text, font=font, fill=fill, anchor="mm")
            ref = np.asarray(ref).astype(int)
            x0, y0, x1, y1 = (int(v) for v in box)
            crop, want = img[y0:y1, x0:x1], ref[y0:y1, x0:x1]
            assert (want.sum(-1) < 600).sum() > 10, text  # the text has pixels of its own
            # the sheet holds exactly that text there: nothing over it, nothing moved
            assert np.abs(crop - want).max() <= 2, text


def _body_color(region: np.ndarray) -> np.ndarray:
    """Mean colour of the mannequin's clothes in ``region`` (the top of a picture): not background,
    not skin, not text, not the face's close-up in the corner (renders.face_closeup)."""
    from renders.face_closeup import FaceInset, inset_side
    from renders.mannequin import BACKGROUND, DEFAULT_VIEW

    inset = FaceInset(inset_side("auto", DEFAULT_VIEW, *SIZE), *SIZE)
    region = region.copy()
    region[: inset.top + inset.side + inset.border, SIZE[0] - inset.side - inset.margin - inset.border:] = BACKGROUND
    r, g, b = region[..., 0], region[..., 1], region[..., 2]
    background = np.abs(region - np.array(BACKGROUND)).sum(-1) < 20
    skin = (r > b + 40) & (r > 120) & (g > 90)
    light = region.sum(-1) > 600
    mask = ~background & ~skin & ~light
    assert mask.sum() > 200
    return region[mask].mean(axis=0)


def test_speakers_are_tinted_apart(sheet):
    from renders.overlay import timeline_geometry

    info, img = sheet
    assert [p.label for p in info["panels"]][:2] == ["guide", "guide"]  # the script's order: guide is tint 0
    top = timeline_geometry(*SIZE, 2).top - 12
    colors = {}
    for p in info["panels"]:
        x0, y0, x1, _ = p.box
        colors.setdefault(p.label, []).append(_body_color(img[y0 : y0 + top, x0:x1]))
    guide, robot = (np.mean(colors[k], axis=0) for k in ("guide", "robot"))
    assert guide[2] > guide[0] + 30 and guide[2] > guide[1]  # blue
    assert robot[1] > robot[0] + 20 and robot[1] > robot[2] + 20  # green


def test_a_gif_of_two_speakers_tints_each_and_its_label(tmp_path, mannequin, tracks):
    from PIL import Image

    from renders.animate import label_color, render_gif
    from renders.mannequin import speaker_tint
    from renders.overlay import label_layout

    tints = [speaker_tint(0), speaker_tint(1)]
    render_gif(tracks[0], tmp_path / "two.gif", size=SIZE, others=tracks[1:], labels=("guide", "robot"),
               tints=tints, mannequin=mannequin)
    im = Image.open(tmp_path / "two.gif")
    im.seek(im.n_frames // 2)
    rgb = np.asarray(im.convert("RGB")).astype(int)
    left, right = rgb[:, : SIZE[0]], rgb[:, SIZE[0]:]
    assert _body_color(left[:90])[2] > _body_color(left[:90])[0] + 30
    assert _body_color(right[:90])[1] > _body_color(right[:90])[0] + 20
    for half, tint, name in ((left, tints[0], "guide"), (right, tints[1], "robot")):  # the label's box: the tint's dark shade
        x0, y0, _, _ = (round(v) for v in label_layout(*SIZE, name).box)  # its top left corner, under the word's band
        assert np.abs(half[y0 + 1, x0 + 1] - np.array(label_color(tint))).max() <= 12, (half[y0 + 1, x0 + 1], label_color(tint))


def test_even_frames_and_a_row_without_gestures(tmp_path, mannequin, tracks):
    from core.motion import MotionClip
    from renders.animate import render_sheet, sheet_frames

    info = render_sheet(tracks, tmp_path / "even.png", size=SIZE, at="even", mannequin=mannequin)
    assert [p.frame for p in info["panels"]] == sheet_frames(tracks[0].n_frames) + sheet_frames(tracks[1].n_frames)
    still = MotionClip(poses=tracks[0].poses[:30], speaker="quiet", words=tracks[0].words)
    info = render_sheet([still], tmp_path / "none.png", size=SIZE, mannequin=mannequin)
    assert [p.frame for p in info["panels"]] == sheet_frames(30) and all(p.gesture is None for p in info["panels"])


def test_a_long_row_wraps(tmp_path, mannequin, tracks):
    from dataclasses import replace

    from PIL import Image

    from renders.animate import render_sheet

    guide = tracks[0]
    many = [replace(k, stroke_frame=min(guide.n_frames - 1, k.stroke_frame + 3 * i))
            for i in range(5) for k in guide.controls if k.kind == "pose"]  # 10 strokes
    clip = replace(guide, controls=many)
    info = render_sheet([clip], tmp_path / "long.png", size=SIZE, columns=4, mannequin=mannequin)
    im = Image.open(tmp_path / "long.png")
    assert im.width == 4 * SIZE[0] and len(info["panels"]) == 10
    rows = sorted({p.box[1] for p in info["panels"]})
    assert len(rows) == 3 and all(b - a >= SIZE[1] for a, b in zip(rows, rows[1:]))
    assert all(p.box[2] <= im.width and p.box[3] <= im.height for p in info["panels"])


# -- command line ------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def motion_file(tmp_path_factory, take):
    path = tmp_path_factory.mktemp("motion") / "take.json"
    take.save(path)
    return path


def test_cli_sheet_of_strokes_from_a_view(tmp_path, motion_file, capsys):
    from PIL import Image

    from sgt_tui.cli import main

    out, sheet = tmp_path / "o.gif", tmp_path / "o.png"
    assert main(["render", str(motion_file), "-o", str(out), "--sheet", str(sheet), "--size", "64",
                 "--view", "side"]) == 0
    err = capsys.readouterr().err
    assert "5 strokes of 2 rows" in err
    assert Image.open(out).size == (128, 64) and Image.open(sheet).width == 3 * 64
    assert main(["render", str(motion_file), "-o", str(out), "--sheet", str(sheet), "--size", "64",
                 "--sheet-at", "even", "--speaker", "robot"]) == 0
    assert "8 frames of 1 row" in capsys.readouterr().err


@pytest.mark.parametrize("tail, message", [(["--view", "back"], "--view"), (["--sheet-at", "words"], "--sheet-at"),
                                           (["--size", "12"], "--size")])
def test_cli_render_bad_view_or_mode(tmp_path, motion_file, capsys, tail, message):
    from sgt_tui.cli import main

    rc = main(["render", str(motion_file), "-o", str(tmp_path / "o.gif"), *tail])
    err = capsys.readouterr().err
    assert rc == 2 and message in err and "Traceback" not in err
    assert not (tmp_path / "o.gif").exists()


def test_library_sheet_size_and_views(tmp_path, capsys):
    from PIL import Image

    from sgt_tui.cli import main

    out = tmp_path / "lib.png"
    assert main(["library", "sheet", "point_front", "point_left", "-o", str(out), "--size", "80",
                 "--view", "top,three-quarter,side"]) == 0
    assert "(top, three-quarter, side)" in capsys.readouterr().err
    img = np.asarray(Image.open(out).convert("RGB")).astype(int)
    assert img.shape[1] == 2 * 3 * 80 and img.shape[0] > 80
    # every picture differs from every other: three views of two gestures (under the views' names,
    # above the gestures' names)
    top = img.shape[0] - 16 - 80
    views = [img[top : top + 80, i * 80 : (i + 1) * 80] for i in range(6)]
    for i in range(6):
        for j in range(i + 1, 6):
            assert np.abs(views[i] - views[j]).mean() > 0.5, (i, j)
    assert main(["library", "sheet", "nod", "-o", str(out), "--size", "90x60"]) == 0
    assert Image.open(out).width == 2 * 90


@pytest.mark.parametrize("tail", [["--size", "0"], ["--size", "big"], ["--view", "back"], ["--view", "front,front"]])
def test_library_sheet_usage_errors(tmp_path, capsys, tail):
    from sgt_tui.cli import main

    rc = main(["library", "sheet", "nod", "-o", str(tmp_path / "x.png"), *tail])
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err
    assert tail[0] in err.strip().splitlines()[-1]  # argparse's usage, then one line that says what
    assert not (tmp_path / "x.png").exists()

"""The preview shows the face: at 320 px the mouth opens and rounds, the eyelids close, the pupils
follow the gaze and the brows rise, in single frames and in GIFs, sheets and videos (every clip's
face reaches the mannequin); a clip without a face shows a resting one.

The expressions read at that size (sgt render's default), and the previews show the face close:

- every two expressions differ on the screen at least as much as one eye shut differs from the
  resting face (the mean absolute difference of the head's pixels; closing an eye is a change the
  preview shows at this size, as the blink test here checks), in the default view, from the front
  and in the face close-up;
- the brows say the expression: level at rest (no frown), a V for angry, raised in the middle for
  sad and afraid, measured on the pixels of the close-up;
- ``--view face`` is a camera that follows the head; GIFs, MP4s and sheets draw a close-up of the
  face in a corner where the head is small (``--face-inset``, on by default at 320 px).
"""

from __future__ import annotations

import numpy as np
import pytest
from test_face_export import talking_face

from core.face import ARKIT_INDEX, EXPRESSIONS, FaceTrack, expression_weights
from core.motion import MotionClip, Track
from core.skeleton import REST_POSE, positions_from_pose

SIZE = 320


@pytest.fixture(scope="module")
def mannequin():
    from renders.gl import RenderSetupError
    from renders.mannequin import Mannequin

    try:
        m = Mannequin(SIZE, SIZE)
    except RenderSetupError as exc:
        pytest.skip(str(exc))
    yield m
    m.close()


def _face(**weights) -> FaceTrack:
    gaze = np.array(weights.pop("gaze", [[0.0, 0.0], [0.0, 0.0]]), float)[None]
    w = np.zeros((1, 52))
    for name, value in weights.items():
        w[0, ARKIT_INDEX[name]] = value
    return FaceTrack(w, gaze)


def _render(m, view="front", **weights):
    from renders.mannequin import FaceFrames

    clip = MotionClip(poses=REST_POSE[None], face=_face(**weights))
    return m.render(clip.positions[0], view=view, face=FaceFrames(clip.face)[0]).astype(int)


def _at(local, view="front"):
    """Pixel (x, y) of a point given in the head's frame, at rest."""
    from renders.face_rig import head_frames
    from renders.mannequin import project

    rot, centre = head_frames(MotionClip(poses=REST_POSE[None]).positions)
    return project(centre[0] + rot[0] @ np.asarray(local, float), SIZE, SIZE, view)


def _window(img, centre, r):
    x, y = (int(round(c)) for c in centre)
    return img[y - r:y + r + 1, x - r:x + r + 1]


def _eye_centres():
    from renders import face_rig

    tf = face_rig.neutral_transforms()
    return [_at(tf[face_rig.PART_INDEX[f"eye_{s}"], :3, 3]) for s in ("l", "r")]


def _mouth_centre():
    from renders import face_rig

    return _at(face_rig.neutral_transforms()[face_rig.PART_INDEX["mouth"], :3, 3])


def _whites(patch) -> int:
    """Eye-white pixels: bright and grey (the background is out of the eye's window)."""
    return int(np.sum((patch.min(axis=-1) > 170) & (np.ptp(patch, axis=-1) < 20)))


def _dark(patch):
    return (patch.sum(axis=-1) < 300) & (np.ptp(patch, axis=-1) < 30)


def _mouth_dark(patch):
    """The mouth's inside: dark red."""
    r, g, b = patch[..., 0], patch[..., 1], patch[..., 2]
    return (r < 150) & (r > g + 25) & (r > b + 15)


def _reds(patch):
    """Lips and the mouth's inside: red well above green."""
    r, g = patch[..., 0], patch[..., 1]
    return r > g + 35


def test_the_mouth_opens_with_the_jaw_and_rounds_with_pucker(mannequin):
    centre = _mouth_centre()
    rest = _window(_render(mannequin), centre, 14)
    opened = _window(_render(mannequin, jawOpen=1.0), centre, 14)
    assert _mouth_dark(opened).sum() > _mouth_dark(rest).sum() + 40
    # Height of the opening: a jaw half open shows about half of it.
    half = _window(_render(mannequin, jawOpen=0.5), centre, 14)
    rows = lambda p: int(np.any(_mouth_dark(p), axis=1).sum())  # noqa: E731
    assert rows(rest) + 2 <= rows(half) <= rows(opened) - 2, (rows(rest), rows(half), rows(opened))

    def width(img):
        cols = np.nonzero(np.any(_reds(_window(img, centre, 20)), axis=0))[0]
        return int(cols.max() - cols.min() + 1)

    rounded = _render(mannequin, mouthPucker=1.0, jawOpen=0.2)
    wide = _render(mannequin, mouthStretchLeft=0.8, mouthStretchRight=0.8, jawOpen=0.2)
    assert width(rounded) + 5 <= width(wide), (width(rounded), width(wide))


def test_the_eyelids_close_with_a_blink_one_eye_at_a_time(mannequin):
    left, right = _eye_centres()  # the character's left eye is on the right of a front view
    assert left[0] > right[0]
    rest = _render(mannequin)
    both = _render(mannequin, eyeBlinkLeft=1.0, eyeBlinkRight=1.0)
    one = _render(mannequin, eyeBlinkLeft=1.0)
    half = _render(mannequin, eyeBlinkLeft=0.5, eyeBlinkRight=0.5)
    for eye in (left, right):
        assert _whites(_window(rest, eye, 5)) >= 15
        assert _whites(_window(both, eye, 5)) == 0
        assert 0 < _whites(_window(half, eye, 5)) < _whites(_window(rest, eye, 5))
    assert _whites(_window(one, left, 5)) == 0 and _whites(_window(one, right, 5)) >= 15


@pytest.mark.parametrize("gaze, dx, dy", [((20.0, 0.0), 1, 0), ((-20.0, 0.0), -1, 0), ((0.0, 15.0), 0, -1)])
def test_the_pupils_follow_the_gaze(mannequin, gaze, dx, dy):
    ahead = _render(mannequin)
    looking = _render(mannequin, gaze=[gaze, gaze])
    for eye in _eye_centres():
        def centroid(img):
            ys, xs = np.nonzero(_dark(_window(img, eye, 6)))
            assert len(xs) >= 4
            return np.array([xs.mean(), ys.mean()])

        moved = centroid(looking) - centroid(ahead)
        # yaw to the character's left: right in a front view; up: up the picture
        assert moved[0] * dx >= 1.0 if dx else abs(moved[0]) < 1.0, moved
        assert moved[1] * dy >= 1.0 if dy else abs(moved[1]) < 1.0, moved


def test_the_brows_rise_and_lower(mannequin):
    from renders import face_rig

    tf = face_rig.neutral_transforms()
    brow = _at(tf[face_rig.PART_INDEX["brow_l"], :3, 3])

    def height(img):
        patch = _window(img, brow, 12)
        ys, _ = np.nonzero((patch.sum(axis=-1) < 330) & (patch[..., 0] > patch[..., 2] + 15))
        return ys.mean()

    rest = height(_render(mannequin))
    assert height(_render(mannequin, browInnerUp=1.0, browOuterUpLeft=1.0)) < rest - 1.5
    assert height(_render(mannequin, browDownLeft=1.0)) > rest + 1.0


def test_a_clip_without_a_face_shows_a_resting_one(mannequin):
    clip = MotionClip(poses=REST_POSE[None])
    plain = mannequin.render(clip.positions[0])
    from renders.mannequin import FaceFrames

    resting = mannequin.render(clip.positions[0], face=FaceFrames(FaceTrack.neutral(1))[0])
    np.testing.assert_array_equal(plain, resting)


def test_face_frames_are_made_a_chunk_at_a_time_and_match_the_face():
    from renders import face_rig
    from renders.mannequin import FaceFrames

    face = talking_face(300)
    frames = FaceFrames(face)
    want = face_rig.part_transforms(face.weights, face.gaze, face_rig.GAZE_GAIN)
    for f in (0, 127, 128, 299, 5, 200, 130, 500):
        np.testing.assert_allclose(frames[f], want[min(f, 299)], atol=1e-12, err_msg=str(f))


def test_tracks_and_joined_utterances_keep_their_faces():
    from renders.clips import concat_clips, track_clip

    face = talking_face(20)
    track = Track(speaker="a", poses=np.tile(REST_POSE, (20, 1)), face=face)
    assert track_clip(track, []).face is face
    a = MotionClip(poses=np.tile(REST_POSE, (5, 1)), face=face.take(slice(0, 5)))
    b = MotionClip(poses=np.tile(REST_POSE, (3, 1)))  # no face: a resting one in the join
    joined = concat_clips([a, b])
    np.testing.assert_array_equal(joined.face.weights[:5], face.weights[:5])
    assert not np.any(joined.face.weights[5:]) and joined.face.n_frames == 8
    assert concat_clips([b, b]).face is None


def _head_box(size=SIZE, view="three-quarter"):
    from renders.face_rig import head_frames
    from renders.mannequin import project

    _, centre = head_frames(MotionClip(poses=REST_POSE[None]).positions)
    x, y = project(centre[0], size, size, view)
    return int(x) - 30, int(y) - 35, int(x) + 30, int(y) + 35


def test_gifs_sheets_and_videos_show_each_clips_face(tmp_path, mannequin):
    from PIL import Image, ImageSequence

    from renders.animate import render_gif, render_mp4, render_sheet

    n = 12
    face = talking_face(n)
    w = face.weights.copy()
    w[:, ARKIT_INDEX["jawOpen"]] = np.where(np.arange(n) % 2, 1.0, 0.0)  # open on odd frames
    talking = MotionClip(poses=np.tile(REST_POSE, (n, 1)), face=FaceTrack(w, face.gaze))
    still = MotionClip(poses=np.tile(REST_POSE, (n, 1)))
    render_gif(talking, tmp_path / "a.gif", mannequin=mannequin, others=[still], labels=("a", "b"))
    frames = [np.asarray(f.convert("RGB")).astype(int) for f in ImageSequence.Iterator(Image.open(tmp_path / "a.gif"))]
    x0, y0, x1, y1 = _head_box()
    left = [f[y0:y1, x0:x1] for f in frames]
    right = [f[y0:y1, SIZE + x0:SIZE + x1] for f in frames]
    assert np.abs(left[1] - left[0]).sum(axis=-1).astype(bool).sum() > 30  # the mouth moved
    assert all(np.array_equal(right[0], r) for r in right)  # the clip without a face did not
    # The sheet's pictures and the video's frames come from the same panels.
    s = render_sheet([talking], tmp_path / "s.png", at="even", n_samples=2, mannequin=mannequin)
    sheet = np.asarray(Image.open(tmp_path / "s.png").convert("RGB")).astype(int)
    shots = [sheet[p.box[1] + y0:p.box[1] + y1, p.box[0] + x0:p.box[0] + x1] for p in s["panels"]]
    assert [p.frame for p in s["panels"]] == [3, 9]
    direct = np.asarray(frames[3])[y0:y1, x0:x1]
    assert np.abs(shots[0] - direct).max() < 60  # same picture (the GIF's palette aside)
    av = pytest.importorskip("av")
    render_mp4([talking], tmp_path / "v.mp4", mannequin=mannequin)
    with av.open(str(tmp_path / "v.mp4")) as f:
        video = [fr.to_ndarray(format="rgb24").astype(int)[y0:y1, x0:x1] for fr in f.decode(video=0)]
    assert np.abs(video[1] - video[0]).sum(axis=-1).astype(bool).sum() > 30


# -- the expressions at the default size, and the close-up -------------------------------------

def test_the_default_size_is_what_the_expressions_are_measured_at():
    from renders.animate import DEFAULT_SIZE

    assert DEFAULT_SIZE == (SIZE, SIZE)


@pytest.mark.parametrize("view", ["default", "front", "face"])
def test_every_two_expressions_differ_on_screen_more_than_one_eye_shut(mannequin, view):
    from renders.face_closeup import pixel_distances, wink_distance
    from renders.mannequin import DEFAULT_VIEW

    view = DEFAULT_VIEW if view == "default" else view
    wink = wink_distance(mannequin, view)
    distances = pixel_distances(mannequin, view)
    assert len(distances) == len(EXPRESSIONS) * (len(EXPRESSIONS) - 1) // 2
    alike = {f"{a}/{b}": round(d, 2) for (a, b), d in distances.items() if d < wink}
    assert not alike, f"{view} at {SIZE} px: these differ less than one eye shut ({wink:.2f}): {alike}"


def test_the_brows_are_level_at_rest_a_v_in_anger_and_slanted_up_in_sadness_and_fear(mannequin):
    """The slant (degrees, positive: the inner ends lower) on the close-up's pixels. At rest the
    brows may not dip in the middle at all (any V reads as a frown); angry, sad and afraid must
    move them at least 12 degrees from it, the right way."""
    from renders.face_closeup import brow_tilt, face_image, rest_positions

    p = rest_positions()
    tilt = {n: brow_tilt(face_image(mannequin, expression_weights(n), "face"), p, "face")
            for n in ("neutral", "angry", "sad", "afraid")}
    assert tilt["neutral"] <= 0.0, f"the resting brows dip in the middle (a frown): {tilt}"
    assert tilt["angry"] - tilt["neutral"] >= 12.0, f"angry's brows are no V: {tilt}"
    assert tilt["neutral"] - tilt["sad"] >= 12.0 and tilt["neutral"] - tilt["afraid"] >= 12.0, \
        f"sad's and afraid's brows do not rise in the middle: {tilt}"


def test_brow_tilt_reads_the_brows_of_a_picture(mannequin):
    """The measure itself: a face with only the inner brows down slants positive, up negative."""
    from core.face import blendshapes
    from renders.face_closeup import brow_tilt, face_image, rest_positions

    p = rest_positions()
    down = brow_tilt(face_image(mannequin, blendshapes({"browDown": 1.0}), "face"), p, "face")
    up = brow_tilt(face_image(mannequin, blendshapes({"browInnerUp": 1.0}), "face"), p, "face")
    assert down > 10 and up < -10, (down, up)
    with pytest.raises(ValueError, match="no brows"):
        brow_tilt(np.full((SIZE, SIZE, 3), 236, np.uint8), p, "face")


def test_the_face_view_follows_the_head(mannequin):
    """The face close-up looks at the head's centre in every frame: a lean moves the body, not
    the head's place in the picture, and the head fills most of it."""
    from renders.face_closeup import head_box
    from renders.face_rig import head_frames
    from renders.mannequin import BACKGROUND, VIEWS, project

    assert VIEWS["face"].on_head and not any(v.on_head for k, v in VIEWS.items() if k != "face")
    pose = REST_POSE.copy()
    leaning = positions_from_pose(pose[None])[0] + np.array([0.15, -0.05, 0.1])  # the whole figure moved
    for positions in (positions_from_pose(pose[None])[0], leaning):
        centre = head_frames(positions[None])[1][0]
        assert np.allclose(project(centre, SIZE, SIZE, "face", head=centre), SIZE / 2)
        image = mannequin.render(positions, view="face").astype(int)
        x0, y0, x1, y1 = head_box(positions, SIZE, SIZE, "face")
        assert (x1 - x0) > 0.4 * SIZE and (y1 - y0) > 0.55 * SIZE
        # the head's skin at the picture's middle, the background at its top corners
        assert np.abs(image[SIZE // 2, SIZE // 2] - np.array(BACKGROUND)).sum() > 60
        assert np.abs(image[2, 2] - np.array(BACKGROUND)).sum() < 10


def test_a_region_is_drawn_with_the_same_pixels_as_the_whole_picture(mannequin):
    """The close-up draws only its crop (a scissor): the box's pixels are those of the whole
    picture, at any place (edges included), and the close-up is the whole picture cropped and
    scaled, also where its crop reaches past the picture (black there, as a crop has it)."""
    from PIL import Image

    from renders.face_closeup import FaceInset
    from renders.mannequin import BODY, FaceFrames

    clip = MotionClip(poses=REST_POSE[None], face=_face(jawOpen=0.8, eyeBlinkLeft=1.0))
    positions, face = clip.positions[0], FaceFrames(clip.face)[0]
    whole = mannequin.render(positions, view="face", face=face)
    for x0, y0, x1, y1 in ((0, 0, SIZE, SIZE), (40, 17, 201, 260), (0, 0, 1, 1), (SIZE - 33, SIZE - 50, SIZE, SIZE)):
        mannequin.render(positions, view="front")  # another picture left in the framebuffer
        part = mannequin.render(positions, view="face", face=face, region=(x0, y0, x1, y1))
        assert np.array_equal(part, whole[y0:y1, x0:x1]), (x0, y0, x1, y1)
    # the next whole picture is whole again (no scissor left behind)
    assert np.array_equal(mannequin.render(positions, view="face", face=face), whole)
    with pytest.raises(ValueError, match="not inside"):
        mannequin.render(positions, view="face", region=(0, 0, SIZE + 1, SIZE))

    # (a second Mannequin would not do: closing one ends the GL display every other one uses)
    for inset in (FaceInset(60, SIZE, SIZE), FaceInset(60, 100, 200)):  # the second's crop starts left of the picture
        picture = Image.fromarray(whole).crop(inset.crop).resize((60, 60), Image.LANCZOS)
        assert np.array_equal(np.asarray(inset.image(mannequin, positions, None, face, BODY)), np.asarray(picture))
    assert FaceInset(60, 100, 200).crop[0] < 0 <= FaceInset(60, SIZE, SIZE).crop[0]


def test_the_inset_is_on_where_the_head_is_small():
    from renders.face_closeup import INSET_BELOW, head_box, inset_side, rest_positions
    from renders.mannequin import DEFAULT_VIEW

    _, y0, _, y1 = head_box(rest_positions(), SIZE, SIZE, DEFAULT_VIEW)
    assert y1 - y0 < INSET_BELOW  # the head at the default size: too small to read by itself
    assert inset_side("auto", DEFAULT_VIEW, SIZE, SIZE) == round(0.34 * SIZE)
    assert inset_side("auto", DEFAULT_VIEW, 800, 800) == 0  # a head 130 px tall reads
    assert inset_side("on", DEFAULT_VIEW, 800, 800) == 272
    assert inset_side("off", DEFAULT_VIEW, SIZE, SIZE) == 0
    assert inset_side("on", "face", SIZE, SIZE) == 0  # never a close-up of the close-up
    with pytest.raises(ValueError, match="auto, on, off"):
        inset_side("big", DEFAULT_VIEW, SIZE, SIZE)


def _corner(image: np.ndarray) -> np.ndarray:
    """Where the inset goes: the top right corner, under the word's line."""
    return image[60:140, SIZE - 100:SIZE - 20]


def _angry_clip(n: int = 6) -> MotionClip:
    w = np.tile(expression_weights("angry"), (n, 1))
    return MotionClip(poses=np.tile(REST_POSE, (n, 1)), face=FaceTrack(w, np.zeros((n, 2, 2))))


def test_gifs_mp4s_and_sheets_show_the_face_close_by_default(tmp_path, mannequin):
    from PIL import Image, ImageSequence

    from renders.animate import render_gif, render_mp4, render_sheet
    from renders.face_closeup import FaceInset, brow_tilt, rest_positions
    from renders.mannequin import BACKGROUND, FaceFrames

    clip = _angry_clip()
    render_gif(clip, tmp_path / "a.gif", mannequin=mannequin)
    render_gif(clip, tmp_path / "off.gif", mannequin=mannequin, face_inset="off")
    frame = np.asarray(next(ImageSequence.Iterator(Image.open(tmp_path / "a.gif"))).convert("RGB")).astype(int)
    plain = np.asarray(next(ImageSequence.Iterator(Image.open(tmp_path / "off.gif"))).convert("RGB")).astype(int)
    assert np.abs(_corner(plain) - np.array(BACKGROUND)).sum(-1).max() < 12  # nothing there without it
    # The corner holds the close-up as FaceInset draws it (the GIF's palette aside), with its angry brows.
    inset = FaceInset(round(0.34 * SIZE), SIZE, SIZE)
    close = np.asarray(inset.image(mannequin, clip.positions[0], None, FaceFrames(clip.face)[0], (0.25, 0.36, 0.55)))
    x, y = SIZE - inset.side - inset.margin, inset.top
    assert np.abs(frame[y:y + inset.side, x:x + inset.side] - close).mean() < 6
    assert brow_tilt(close, rest_positions(), "face") > 8  # the V reads at the inset's size (no head at rest there)
    # The same corner in a sheet's picture and an MP4's frame.
    s = render_sheet([clip], tmp_path / "s.png", at="even", n_samples=1, mannequin=mannequin)
    sheet = np.asarray(Image.open(tmp_path / "s.png").convert("RGB")).astype(int)
    x0, y0, *_ = s["panels"][0].box
    assert np.abs(_corner(sheet[y0:y0 + SIZE, x0:x0 + SIZE]) - _corner(frame)).mean() < 6
    av = pytest.importorskip("av")
    render_mp4([clip], tmp_path / "v.mp4", mannequin=mannequin)
    with av.open(str(tmp_path / "v.mp4")) as f:
        video = next(f.decode(video=0)).to_ndarray(format="rgb24").astype(int)
    assert np.abs(_corner(video) - _corner(frame)).mean() < 8


def test_sgt_render_draws_the_inset_unless_asked_not_to_and_renders_the_face_view(tmp_path):
    """What users get from the command: the default GIF has the close-up in its corner,
    --face-inset off has none, --view face is the close-up itself (no inset on it)."""
    from PIL import Image

    from core.motion import save_motion
    from renders.mannequin import BACKGROUND
    from sgt_tui.cli import main

    clip = _angry_clip()
    clip.face = talking_face(clip.n_frames)
    save_motion(tmp_path / "take.json", [clip])

    def first(name: str, *options: str) -> np.ndarray:
        assert main(["render", str(tmp_path / "take.json"), "-o", str(tmp_path / name), *options]) == 0
        return np.asarray(Image.open(tmp_path / name).convert("RGB")).astype(int)

    shown, off, face = first("a.gif"), first("off.gif", "--face-inset", "off"), first("face.gif", "--view", "face")
    away = np.abs(_corner(shown) - np.array(BACKGROUND)).sum(-1)
    assert (away > 60).mean() > 0.5  # the close-up fills the corner
    assert np.abs(_corner(off) - np.array(BACKGROUND)).sum(-1).max() < 12
    assert np.abs(face[SIZE // 2, SIZE // 2] - np.array(BACKGROUND)).sum() > 60  # the head in the middle
    assert first("on.gif", "--view", "face", "--face-inset", "on").tolist() == face.tolist()

"""The preview shows the face: at 320 px the mouth opens and rounds, the eyelids close, the pupils
follow the gaze and the brows rise, in single frames and in GIFs, sheets and videos (every clip's
face reaches the mannequin); a clip without a face shows a resting one."""

from __future__ import annotations

import numpy as np
import pytest
from test_face_export import talking_face

from core.face import ARKIT_INDEX, FaceTrack
from core.motion import MotionClip, Track
from core.skeleton import REST_POSE

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

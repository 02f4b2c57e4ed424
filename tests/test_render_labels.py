"""The labels of pictures side by side (A/B of `sgt render --compare`, a speaker's name) never
cover the spoken word: they sit at the left under the band the word's box can take
(renders.overlay.label_layout), cut short before the face's close-up.

- the real `sgt render A --compare B` at three sizes: at every frame of the GIF, no pixel of a
  label's colour inside the word's box (renders.overlay.word_box), and the label drawn under it;
- each picture drawn with and without its label, its word and its close-up (no palette between):
  the pixels the label changes never meet those the word or the close-up change, for every
  word of the takes and the longest label.
"""

from __future__ import annotations

import numpy as np
import pytest

from core.motion import load_motion_file
from core.skeleton import FPS
from renders.clips import track_clip
from sgt_tui.cli import main

#: A word as wide as it gets at the top, and a long name: the label would cover the word at the
#: top left (as it did) at every size below.
A = "@seed 2\nguide: Everything in the marmalade department [pose:point_right] is remarkable.\n"
B = "@seed 4\nguide: Look at the shelf [pose:point_left] over there.\n"
B_NAME = "a_take_with_a_rather_long_name"


@pytest.fixture(scope="module")
def takes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("labels")
    for name, text in (("a", A), (B_NAME, B)):
        (folder / f"{name}.sgt").write_text(text)
        assert main(["generate", str(folder / f"{name}.sgt"), "-o", str(folder / f"{name}.json")]) == 0
    clips = [track_clip(m.tracks[0], m.clips) for m in (load_motion_file(folder / f"{n}.json") for n in ("a", B_NAME))]
    return folder, clips


def _near(image: np.ndarray, color, tolerance: int = 10) -> np.ndarray:
    return np.abs(image - np.array(color)).max(axis=-1) <= tolerance


def _solid(image: np.ndarray, color) -> np.ndarray:
    """The pixels of ``color`` that begin a 2 x 2 block of it: a label's box, not the odd pixel
    of a word's anti-aliased edge that the GIF's palette maps near it."""
    near = _near(image, color)
    out = np.zeros_like(near)
    out[:-1, :-1] = near[:-1, :-1] & near[1:, :-1] & near[:-1, 1:] & near[1:, 1:]
    return out


@pytest.mark.parametrize("size, inset", [((120, 120), "on"), ((200, 200), "auto"), ((320, 240), "off")])
def test_compare_labels_never_cover_the_word_at_any_frame(takes, tmp_path, size, inset):
    from PIL import Image

    from renders.animate import label_color
    from renders.mannequin import speaker_tint
    from renders.overlay import caption_bottom, frame_word, word_box

    folder, clips = takes
    gif = tmp_path / "compare.gif"
    assert main(["render", str(folder / "a.json"), "--compare", str(folder / f"{B_NAME}.json"), "-o", str(gif),
                 "--size", f"{size[0]}x{size[1]}", "--face-inset", inset]) == 0
    w, h = size
    badge = label_color(speaker_tint(0))  # one speaker, two takes: both labels in its colour
    im = Image.open(gif)
    assert im.n_frames == max(c.n_frames for c in clips)
    worded = 0
    for f in range(im.n_frames):
        im.seek(f)
        frame = np.asarray(im.convert("RGB")).astype(int)
        for k, clip in enumerate(clips):
            panel = frame[:, k * w:(k + 1) * w]
            word = frame_word(clip.words, min(f, clip.n_frames - 1))
            labelled = _solid(panel, badge)
            labelled[:, w // 2:] = False  # the label starts at the left; the close-up's frame, at the right, has its colour
            ys, _ = np.nonzero(labelled)
            assert ys.size > 10, f"frame {f}, panel {'AB'[k]}: no label drawn"
            assert ys.min() >= caption_bottom(w, h), f"frame {f}, panel {'AB'[k]}: the label reaches into the word's band"
            box = word_box(w, h, word)
            if box is None:
                continue
            worded += 1
            x0, y0, x1, y1 = (int(np.floor(box[0])), int(box[1]), int(np.ceil(box[2])), int(box[3]))
            covered = labelled[y0:y1 + 1, max(0, x0):x1 + 1].sum()
            assert covered == 0, f"frame {f}, panel {'AB'[k]}: {covered} pixels of the label on the word '{word}'"
            assert _near(panel[y0 + 1:y1, max(0, x0) + 3:x1 - 2], (255, 255, 255), 6).mean() > 0.3  # the word's white box
    assert worded > im.n_frames  # words in most frames of both panels


@pytest.mark.parametrize("size", [(96, 96), (160, 160), (480, 240)])
def test_a_label_changes_no_pixel_of_the_word_or_the_close_up(takes, size):
    from renders.animate import _Panel
    from renders.face_closeup import FaceInset, inset_side
    from renders.gl import RenderSetupError
    from renders.mannequin import Mannequin

    _, clips = takes
    try:
        m = Mannequin(*size)
    except RenderSetupError as exc:  # pragma: no cover - machines without EGL/OSMesa
        pytest.skip(f"no offscreen GL: {exc}")
    inset = FaceInset(inset_side("on", "three-quarter", *size), *size)
    name = f"B {B_NAME}"
    try:
        for clip in clips:
            frames = {}  # a frame of every word (its middle), and one before the first word
            for word in clip.words:
                frames.setdefault(word.word, int((word.start + word.end) / 2 * FPS))
            frames[""] = 0
            for f in frames.values():
                def image(clip=clip, f=f, label=None, inset=None, word=True):
                    return np.asarray(_Panel(m, clip, label, inset=inset).image(f, word=word), dtype=int)

                bare = image(word=False)
                by_label = np.any(image(word=False, label=name, inset=inset) != image(word=False, inset=inset), axis=-1)
                by_word = np.any(image() != bare, axis=-1)
                by_inset = np.any(image(word=False, inset=inset) != bare, axis=-1)
                assert by_label.sum() > 20
                assert not (by_label & by_word).any(), f"frame {f}: the label is drawn on the word"
                assert by_inset.any() and not (by_label & by_inset).any(), f"frame {f}: the label runs into the close-up"
                labelled = image(label=name, inset=inset)  # all of it: the word and the close-up as without the label
                assert (labelled[by_word | by_inset] == image(inset=inset)[by_word | by_inset]).all()
    finally:
        m.close()

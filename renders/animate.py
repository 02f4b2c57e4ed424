"""Preview GIFs and MP4 videos (with the speech), side-by-side panels and contact sheets of
motion clips.

Frames are rendered one at a time with one :class:`~renders.mannequin.Mannequin`,
decorated (:mod:`renders.overlay`), mapped to one shared palette and streamed into a
:class:`~renders.gifwriter.GifWriter`, so memory does not grow with the clip length.
Every output is written with :func:`core.fileio.atomic_write`. With ``jobs`` above 1, a take
of at least :data:`PARALLEL_FRAMES` frames is drawn (and, for a GIF, mapped to the palette) in
that many worker processes (:mod:`renders.frames`) while this process encodes, frame by
frame in order: the same bytes for any ``jobs``.

Each clip's face (``clip.face``, :class:`core.face.FaceTrack`) moves the mannequin's face (lip sync,
blinks, gaze); a clip without one shows a resting face. ``face_inset`` (``auto``, ``on``, ``off``;
:mod:`renders.face_closeup`) draws a close-up of the head in each picture's top right corner,
framed in the body's colour: by default wherever the head is drawn too small for its face to read
(at 320 px, the default size, it is about 50 pixels tall).

Panels side by side are told apart by a label each (the speaker's name, or A/B for a
comparison) and, given ``tints``, by the colour of the mannequin's body; the label's box is
drawn in a dark shade of the same colour (:func:`label_color`), at the left under the spoken
word's band (:func:`renders.overlay.label_layout`: never over the word), cut short before the
face's close-up.
"""

from __future__ import annotations

import contextlib
import io
import math
from dataclasses import dataclass

import numpy as np

from core.cancel import check
from core.counting import plural
from core.fileio import atomic_write
from core.hands import hand_positions
from core.motion import MotionClip
from core.skeleton import FPS, seconds_to_frame
from renders import overlay
from renders.face_closeup import FaceInset, inset_side
from renders.frames import Workers
from renders.gifwriter import GifWriter, build_palette, frame_delays_cs, quantize
from renders.mannequin import BODY, DEFAULT_VIEW, FaceFrames, Mannequin
from renders.video import write_mp4

DEFAULT_SIZE = (320, 320)
PALETTE_SAMPLES = 6
#: The shortest take drawn in worker processes (6 s): a worker's start (imports, GL context,
#: meshes) costs about what it draws in its first second.
PARALLEL_FRAMES = 90


def _sample_frames(n_frames: int, k: int) -> list[int]:
    k = max(1, min(k, n_frames))
    return sorted({min(n_frames - 1, int((i + 0.5) * n_frames / k)) for i in range(k)})


def label_color(tint) -> tuple[int, int, int]:
    """The sRGB colour (0..255) of a label for a body in ``tint`` (linear RGB): the same hue,
    dark enough for white text."""
    c = np.clip(np.asarray(tint, np.float64) * 0.45, 0.0, 1.0)
    srgb = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    return tuple(int(round(255 * v)) for v in srgb)


class _Panel:
    """One clip drawn into a width x height panel, from one view, in one tint, with its overlays
    and, given an ``inset`` (:class:`renders.face_closeup.FaceInset`), a close-up of its face."""

    def __init__(self, mannequin, clip: MotionClip, label: str | None, *, view: str = DEFAULT_VIEW,
                 tint=BODY, inset: FaceInset | None = None) -> None:
        self.m = mannequin
        self.clip = clip
        self.label = label
        self.view = view
        self.tint = tuple(tint)
        self.inset = inset
        self.hands = hand_positions(clip.positions, clip.hands)
        self.face = FaceFrames(clip.face) if clip.face is not None else None

    def image(self, frame: int, *, word: bool = True, legend: bool = True):
        from PIL import Image, ImageDraw

        f = min(frame, self.clip.n_frames - 1)
        face = self.face[f] if self.face is not None else None
        img = Image.fromarray(self.m.render(self.clip.positions[f], self.hands[f], view=self.view, tint=self.tint,
                                            face=face))
        overlay.decorate(img, f, self.clip, word=word, legend=legend)
        if self.inset is not None:
            self.inset.draw(img, self.m, self.clip.positions[f], self.hands[f], face, self.tint, label_color(self.tint))
        if self.label:
            overlay.draw_label(ImageDraw.Draw(img), img.width, img.height, self.label, color=label_color(self.tint),
                               word=overlay.frame_word(self.clip.words, f) if word else None, right=self.label_end(img.width))
        return img

    def label_end(self, width: int) -> float | None:
        """Where the label must end: before the face's close-up (its frame, and a gap), if any."""
        if self.inset is None:
            return None
        i = self.inset
        return width - i.margin - i.side - i.border - max(2, i.border * 2)


def _compose(panels, frame: int):
    from PIL import Image

    check()  # a frame at a time: ctrl+c stops a render here, whatever swallowed it on its way
    images = [p.image(frame) for p in panels]
    if len(images) == 1:
        return images[0]
    w = sum(i.width for i in images)
    out = Image.new("RGB", (w, images[0].height))
    x = 0
    for i in images:
        out.paste(i, (x, 0))
        x += i.width
    return out


def _inset(mode: str, view: str, width: int, height: int) -> FaceInset | None:
    """The face close-up for pictures of ``width`` x ``height`` from ``view`` (None: none)."""
    side = inset_side(mode, view, width, height)
    return FaceInset(side, width, height) if side else None


def _panels(m, clip, compare, others, labels, view, tints, inset=None) -> list[_Panel]:
    clips = [clip] + ([compare] if compare is not None else []) + list(others)
    if labels is None and len(clips) > 1:
        labels = tuple("ABCDEFGHIJ"[i % 10] for i in range(len(clips)))
    tints = list(tints) if tints is not None else [BODY] * len(clips)
    if len(tints) != len(clips):
        raise ValueError(f"{len(tints)} tints for {len(clips)} panels")
    return [_Panel(m, c, labels[i] if labels else None, view=view, tint=tints[i], inset=inset) for i, c in enumerate(clips)]


def _worker_draw(clips, labels, tints, view: str, size, face_inset: str):
    """In a worker process (:mod:`renders.frames`): its own mannequin and panels, and the
    function that draws frame f (RGB (H, W, 3)) or, given a palette, its palette indices."""
    m = Mannequin(*size)
    panels = _panels(m, clips[0], None, clips[1:], labels, view, tints, _inset(face_inset, view, *size))
    quantizers: dict[bytes, object] = {}

    def draw(f: int, palette: bytes | None):
        image = _compose(panels, f)
        if palette is None:
            return np.asarray(image)
        if palette not in quantizers:
            from PIL import Image

            quantizers[palette] = Image.new("P", (1, 1))
            quantizers[palette].putpalette(palette)
        return quantize(image, quantizers[palette])

    return draw


def _workers(jobs: int, n_frames: int, clips, labels, tints, view: str, size, face_inset: str):
    """Worker processes drawing these panels (a context manager giving :class:`Workers`, or None
    where this process draws alone)."""
    if jobs <= 1 or n_frames < PARALLEL_FRAMES:
        return contextlib.nullcontext()
    return Workers(jobs, _worker_draw, (list(clips), labels, tints, view, tuple(size), face_inset))


def render_gif(clip: MotionClip, path, *, size=DEFAULT_SIZE, compare: MotionClip | None = None,
               labels: tuple[str, ...] | None = None, progress=None, mannequin=None, others=(),
               view: str = DEFAULT_VIEW, tints=None, face_inset: str = "auto", jobs: int = 1) -> dict:
    """Render ``clip`` (and, side by side, ``compare`` and ``others``, each with its label and,
    with ``tints``, its body colour) to a looping 15 fps GIF at ``path``, seen from ``view``
    (:data:`renders.mannequin.VIEWS`), with the face's close-up as ``face_inset`` says
    (:data:`renders.face_closeup.INSET_MODES`); frames drawn in ``jobs`` worker processes for a
    long take (the same bytes).

    Returns a summary dict: frames, width, height, duration_s, bytes, platform.
    """
    width, height = size
    own = mannequin is None
    inset = _inset(face_inset, view, width, height)
    m = mannequin or Mannequin(width, height)
    try:
        panels = _panels(m, clip, compare, others, labels, view, tints, inset)
        n = max(p.clip.n_frames for p in panels)
        # Started first: they import and build their meshes while this process draws the samples.
        with _workers(jobs, n, [p.clip for p in panels], tuple(p.label for p in panels),
                      [p.tint for p in panels], view, size, face_inset) as workers:
            samples = {f: _compose(panels, f) for f in _sample_frames(n, PALETTE_SAMPLES)}  # kept: a few frames
            palette, pimg = build_palette(samples.values(), overlay.FIXED_COLORS)
            first = next(iter(samples.values()))
            writer = GifWriter(first.width, first.height, palette)
            delays = frame_delays_cs(n)
            if workers is not None:
                samples.clear()
                indices = workers.map(n, palette)
            else:
                indices = (quantize(samples.pop(f) if f in samples else _compose(panels, f), pimg) for f in range(n))
            for f, frame in enumerate(indices):
                writer.add(frame, delays[f])
                if progress:
                    progress(f + 1, n, "frames")
        data = writer.getvalue()
        atomic_write(path, data)
        return {"frames": n, "width": writer.width, "height": writer.height,
                "duration_s": sum(delays) / 100, "bytes": len(data), "platform": m.platform}
    finally:
        if own:
            m.close()


def render_mp4(clips: list[MotionClip], path, *, labels: tuple[str, ...] | None = None, audio=None,
               sample_rate: int | None = None, size=DEFAULT_SIZE, progress=None, mannequin=None,
               view: str = DEFAULT_VIEW, tints=None, face_inset: str = "auto", jobs: int = 1) -> dict:
    """Render ``clips`` side by side (each with its label and tint) to a 15 fps H.264 MP4 at
    ``path``, seen from ``view``, with the face's close-up as ``face_inset`` says and
    ``audio`` (mono, sample 0 with frame 0; :mod:`renders.audio_mix`) as its AAC track; frames
    drawn in ``jobs`` worker processes for a long take (the same bytes).

    Returns a summary dict: frames, width, height, duration_s, bytes, platform, audio_s.
    """
    width, height = size
    own = mannequin is None
    inset = _inset(face_inset, view, width, height)
    m = mannequin or Mannequin(width, height)
    try:
        panels = _panels(m, clips[0], None, clips[1:], labels, view, tints, inset)
        n = max(p.clip.n_frames for p in panels)
        with _workers(jobs, n, [p.clip for p in panels], tuple(p.label for p in panels),
                      [p.tint for p in panels], view, size, face_inset) as workers:
            frames = workers.map(n) if workers is not None else (np.asarray(_compose(panels, f)) for f in range(n))
            info = write_mp4(path, frames, audio=audio, sample_rate=sample_rate, n_frames=n, progress=progress)
        return {"frames": n, "width": width * len(panels), "height": height, "duration_s": n / FPS,
                "bytes": info["bytes"], "platform": m.platform,
                "audio_s": None if audio is None else n / FPS}
    finally:
        if own:
            m.close()


# -- contact sheet -----------------------------------------------------------------------

SHEET_COLUMNS = 4
SHEET_FRAMES = 8
#: What a sheet shows: every pose control's stroke frame, or frames evenly spaced.
SHEET_MODES = ("strokes", "even")


def sheet_frames(n_frames: int, n_samples: int = SHEET_FRAMES) -> list[int]:
    """Frames sampled evenly along the utterance (middle of each of ``n_samples`` parts)."""
    k = max(1, min(n_samples, n_frames))
    return [min(n_frames - 1, int((i + 0.5) * n_frames / k)) for i in range(k)]


def gesture_label(control) -> str:
    """A pose control as the script writes it: ``point_right x2 flip``."""
    o = control.options or {}
    parts = [control.name]
    if o.get("speed", 1) not in (1, None):
        parts.append(f"x{o['speed']}")
    if o.get("flip"):
        parts.append("flip")
    return " ".join(parts)


def marked_word(words, frame: int) -> str | None:
    """The word whose onset is nearest ``frame`` (a pose control's ``word_frame``; the later
    word on a tie), or None without words."""
    best = None
    for w in words or ():
        d = abs(seconds_to_frame(w.start) - frame)
        if best is None or d <= best[0]:
            best = (d, w.word)
    return best[1] if best else None


@dataclass
class SheetPanel:
    """One picture of a sheet: its row (``row``, the row's label), the clip frame it shows,
    what it is captioned with (``lines``: text, centre (x, y), font size, bold, colour) and its
    place ``box`` (x0, y0, x1, y1) on the sheet (the picture; the caption is under it)."""

    row: int
    label: str | None
    frame: int
    gesture: str | None
    word: str | None
    box: tuple[int, int, int, int]
    lines: list


def _sheet_items(clip: MotionClip, at: str, n_samples: int):
    """(frame, gesture, word, caption lines as (text, bold, dim)) of the pictures of one row, a
    note for its band, and what they show: "strokes", or "even" (evenly spaced frames: asked
    for, or a row without pose controls)."""
    strokes = sorted((c for c in clip.controls if c.kind == "pose"),
                     key=lambda c: (c.stroke_frame if c.stroke_frame is not None else c.start_frame, c.line, c.col))
    last = clip.n_frames - 1
    if at == "strokes" and strokes:
        items = []
        for c in strokes:
            if c.stroke_frame is not None:
                f, where = c.stroke_frame, c.word_frame if c.word_frame is not None else c.stroke_frame
            else:  # a gesture without a stroke keyframe: its middle
                f = where = (c.start_frame + max(c.start_frame, c.end_frame - 1)) // 2
            f = min(max(0, f), last)
            word = marked_word(clip.words, where)
            items.append((f, gesture_label(c), word, [(gesture_label(c), True, False),
                                                      (f"“{word}”" if word else "(no word)", False, not word),
                                                      (f"frame {f} · {f / FPS:.2f} s", False, True)]))
        return items, plural(len(items), "gesture"), "strokes"
    items = []
    for f in sheet_frames(clip.n_frames, n_samples):
        word = overlay.frame_word(clip.words, f)
        playing = [gesture_label(c) for c in strokes if c.start_frame <= f < c.end_frame]
        items.append((f, playing[0] if playing else None, word, [(word or "—", True, not word),
                                                                 (", ".join(playing), False, False),
                                                                 (f"frame {f} · {f / FPS:.2f} s", False, True)]))
    note = plural(len(items), "evenly spaced frame")
    if at == "strokes":
        note = "no marked gestures: " + note
    return items, note, "even"


def sheet_layout(width: int, height: int, counts: list[int], columns: int = SHEET_COLUMNS, title_lines: int = 1) -> dict:
    """Geometry of a contact sheet of pictures ``width`` x ``height``: rows of ``counts[i]``
    pictures each (one row per speaker), wrapped at ``columns`` a line, under a title of
    ``title_lines`` lines (``title_line``: their spacing)."""
    s = overlay.scale(width, height)
    cols = max(1, min(columns, max(counts, default=1)))
    lines = [max(1, math.ceil(c / cols)) for c in counts]
    fonts = (max(9, round(16 * s)), max(8, round(14 * s)), max(8, round(12 * s)))
    title_line = math.ceil(1.25 * fonts[0])
    title = max(16, round(30 * s)) + (max(1, title_lines) - 1) * title_line
    band = max(14, round(26 * s))
    pad = max(3, round(8 * s))
    # The caption's three lines (gesture, word, frame), their centres spaced by their font sizes.
    centres = [pad / 2 + 0.65 * fonts[0]]
    for a, b in zip(fonts, fonts[1:]):
        centres.append(centres[-1] + 0.6 * a + 0.75 * b)
    caption = math.ceil(centres[-1] + 0.6 * fonts[-1] + pad / 2)
    tops, y = [], title
    for n in lines:
        tops.append(y)
        y += band + n * (height + caption)
    return {"cols": cols, "lines": lines, "title": title, "title_line": title_line, "band": band, "caption": caption,
            "row_tops": tops, "size": (cols * width, y), "pad": pad, "fonts": fonts, "caption_lines": centres}


def render_sheet(clips: list[MotionClip], path, *, labels: tuple[str, ...] | None = None, size=DEFAULT_SIZE,
                 at: str = "strokes", view: str = DEFAULT_VIEW, tints=None, columns: int = SHEET_COLUMNS,
                 n_samples: int = SHEET_FRAMES, title: str | None = None, mannequin=None, face_inset: str = "auto") -> dict:
    """A PNG contact sheet of ``clips`` (one row per clip: a speaker's track, or a take of a
    comparison), each row under a band with its label and tint, wrapped at ``columns``
    pictures a line. ``at="strokes"``: a picture at every pose control's stroke frame,
    captioned with the gesture, the word it marks and the frame; a row without pose controls
    falls back to ``n_samples`` evenly spaced frames, as ``at="even"`` does for every row
    (captioned with the word spoken then and the gesture playing). Each picture has the face's
    close-up as ``face_inset`` says.

    Returns frames (every picture's, row by row), panels (:class:`SheetPanel`), width,
    height, platform, the title's lines (wrapped to the sheet's width, never cut short on a
    narrow sheet; at most 4) and rows (each row's label, number of pictures and ``at``:
    "strokes", or "even" for evenly spaced frames).
    """
    from PIL import Image, ImageDraw

    if at not in SHEET_MODES:
        raise ValueError(f"unknown sheet mode '{at}': use {' or '.join(SHEET_MODES)}")
    clips = list(clips)
    width, height = size
    tints = list(tints) if tints is not None else [BODY] * len(clips)
    labels = list(labels) if labels else [c.speaker or "unnamed" for c in clips]
    rows = [_sheet_items(c, at, n_samples) for c in clips]
    counts = [len(items) for items, _, _ in rows]
    lay = sheet_layout(width, height, counts, columns)
    if title is None:
        title = " / ".join(c.text for c in clips if c.text) or "(no text)"
    tf = overlay.font(lay["fonts"][0], bold=True)
    title_lines = overlay.wrap(title, tf, lay["size"][0] - 2 * lay["pad"])  # a narrow sheet: on more lines, not cut
    if len(title_lines) > 1:
        lay = sheet_layout(width, height, counts, columns, title_lines=len(title_lines))
    own = mannequin is None
    inset = _inset(face_inset, view, width, height)
    m = mannequin or Mannequin(width, height)
    try:
        sheet = Image.new("RGB", lay["size"], overlay.WHITE)
        d = ImageDraw.Draw(sheet)
        pad, (big, mid, small) = lay["pad"], lay["fonts"]
        first = (lay["title"] - (len(title_lines) - 1) * lay["title_line"]) / 2
        for i, line in enumerate(title_lines):
            d.text((pad, first + i * lay["title_line"]), line, font=tf, fill=overlay.INK, anchor="lm")
        panels: list[SheetPanel] = []
        for r, (clip, (items, note, _)) in enumerate(zip(clips, rows)):
            top = lay["row_tops"][r]
            color = label_color(tints[r])
            # The band: the label in white on the row's colour (as in the animation), then what the row shows.
            bh = lay["band"]
            d.rectangle([0, top, lay["size"][0] - 1, top + bh - 1], fill=overlay.TRACK)
            nf = overlay.font(mid, bold=True)
            x = pad
            chip = d.textbbox((x + pad, top + bh / 2), labels[r], font=nf, anchor="lm")
            d.rectangle([x, top + 2, chip[2] + pad, top + bh - 3], fill=color)
            d.text((x + pad, top + bh / 2), labels[r], font=nf, fill=overlay.WHITE, anchor="lm")
            x = chip[2] + 2 * pad
            d.text((x, top + bh / 2), overlay.fit(note, overlay.font(small), lay["size"][0] - x - pad),
                   font=overlay.font(small), fill=overlay.SOFT_INK, anchor="lm")
            panel = _Panel(m, clip, None, view=view, tint=tints[r], inset=inset)
            for k, (f, gesture, word, caption) in enumerate(items):
                line, c = divmod(k, lay["cols"])
                x = c * width
                y = top + bh + line * (height + lay["caption"])
                sheet.paste(panel.image(f, word=False, legend=False), (x, y))
                cy = y + height
                placed = []
                for i, (text, bold, dim) in enumerate(caption):
                    if not text:
                        continue
                    size_px = (big, mid, small)[i]
                    font = overlay.font(size_px, bold=bold)
                    text = overlay.fit(text, font, width - 2 * pad)
                    centre = (x + width / 2, cy + lay["caption_lines"][i])
                    fill = overlay.SOFT_INK if dim else overlay.INK
                    d.text(centre, text, font=font, fill=fill, anchor="mm")
                    placed.append((text, centre, size_px, bold, fill))
                if c:
                    d.line([(x, y), (x, cy + lay["caption"] - 1)], fill=overlay.TRACK, width=1)
                panels.append(SheetPanel(r, labels[r], f, gesture, word, (x, y, x + width, y + height), placed))
        buf = io.BytesIO()
        sheet.save(buf, format="PNG", optimize=False)
        atomic_write(path, buf.getvalue())
        return {"frames": [p.frame for p in panels], "panels": panels, "width": sheet.width, "height": sheet.height,
                "platform": m.platform, "title": title_lines,
                "rows": [{"label": labels[r], "pictures": counts[r], "at": mode} for r, (_, _, mode) in enumerate(rows)]}
    finally:
        if own:
            m.close()

"""Preview GIFs and MP4 videos (with the speech), side-by-side panels and contact sheets of
motion clips.

Frames are rendered one at a time with one :class:`~renders.mannequin.Mannequin`,
decorated (:mod:`renders.overlay`), mapped to one shared palette and streamed into a
:class:`~renders.gifwriter.GifWriter`, so memory does not grow with the clip length.
Every output is written with :func:`core.fileio.atomic_write`.
"""

from __future__ import annotations

import io
import math

import numpy as np

from core.fileio import atomic_write
from core.hands import hand_positions
from core.motion import MotionClip
from core.skeleton import FPS
from renders import overlay
from renders.gifwriter import GifWriter, build_palette, frame_delays_cs, quantize
from renders.mannequin import Mannequin
from renders.video import write_mp4

DEFAULT_SIZE = (320, 320)
PALETTE_SAMPLES = 6


def _sample_frames(n_frames: int, k: int) -> list[int]:
    k = max(1, min(k, n_frames))
    return sorted({min(n_frames - 1, int((i + 0.5) * n_frames / k)) for i in range(k)})


class _Panel:
    """One clip drawn into a width x height panel, with its overlays."""

    def __init__(self, mannequin, clip: MotionClip, label: str | None) -> None:
        self.m = mannequin
        self.clip = clip
        self.label = label
        self.hands = hand_positions(clip.positions, clip.hands)

    def image(self, frame: int, **kw):
        from PIL import Image

        f = min(frame, self.clip.n_frames - 1)
        img = Image.fromarray(self.m.render(self.clip.positions[f], self.hands[f]))
        return overlay.decorate(img, f, self.clip, label=self.label, **kw)


def _compose(panels, frame: int):
    from PIL import Image

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


def _panels(m, clip, compare, others, labels) -> list[_Panel]:
    clips = [clip] + ([compare] if compare is not None else []) + list(others)
    if labels is None and len(clips) > 1:
        labels = tuple("ABCDEFGHIJ"[i % 10] for i in range(len(clips)))
    return [_Panel(m, c, labels[i] if labels else None) for i, c in enumerate(clips)]


def render_gif(clip: MotionClip, path, *, size=DEFAULT_SIZE, compare: MotionClip | None = None,
               labels: tuple[str, ...] | None = None, progress=None, mannequin=None, others=()) -> dict:
    """Render ``clip`` (and, side by side, ``compare`` and ``others``, each with its label) to a
    looping 15 fps GIF at ``path``.

    Returns a summary dict: frames, width, height, duration_s, bytes, platform.
    """
    width, height = size
    own = mannequin is None
    m = mannequin or Mannequin(width, height)
    try:
        panels = _panels(m, clip, compare, others, labels)
        n = max(p.clip.n_frames for p in panels)
        samples = [_compose(panels, f) for f in _sample_frames(n, PALETTE_SAMPLES)]
        palette, pimg = build_palette(samples, overlay.FIXED_COLORS)
        writer = GifWriter(samples[0].width, samples[0].height, palette)
        delays = frame_delays_cs(n)
        for f in range(n):
            writer.add(quantize(_compose(panels, f), pimg), delays[f])
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
               sample_rate: int | None = None, size=DEFAULT_SIZE, progress=None, mannequin=None) -> dict:
    """Render ``clips`` side by side (each with its label) to a 15 fps H.264 MP4 at ``path``,
    with ``audio`` (mono, sample 0 with frame 0; :mod:`renders.audio_mix`) as its AAC track.

    Returns a summary dict: frames, width, height, duration_s, bytes, platform, audio_s.
    """
    width, height = size
    own = mannequin is None
    m = mannequin or Mannequin(width, height)
    try:
        panels = _panels(m, clips[0], None, clips[1:], labels)
        n = max(p.clip.n_frames for p in panels)
        info = write_mp4(path, (np.asarray(_compose(panels, f)) for f in range(n)), audio=audio, sample_rate=sample_rate,
                         n_frames=n, progress=progress)
        return {"frames": n, "width": width * len(panels), "height": height, "duration_s": n / FPS,
                "bytes": info["bytes"], "platform": m.platform,
                "audio_s": None if audio is None else n / FPS}
    finally:
        if own:
            m.close()


# -- contact sheet -----------------------------------------------------------------------

SHEET_COLUMNS = 4
SHEET_FRAMES = 8


def sheet_layout(width: int, height: int, n_samples: int) -> dict:
    """Geometry of a contact sheet of ``n_samples`` cells of ``width`` x ``height``."""
    s = overlay.scale(width, height)
    cols = max(1, min(SHEET_COLUMNS, n_samples))
    rows = math.ceil(n_samples / cols)
    caption = max(18, round(40 * s))
    header = max(16, round(30 * s))
    return {"cols": cols, "rows": rows, "caption": caption, "header": header,
            "size": (cols * width, header + rows * (height + caption))}


def sheet_frames(n_frames: int, n_samples: int = SHEET_FRAMES) -> list[int]:
    """Frames sampled evenly along the utterance (middle of each of ``n_samples`` parts)."""
    k = max(1, min(n_samples, n_frames))
    return [min(n_frames - 1, int((i + 0.5) * n_frames / k)) for i in range(k)]


def render_sheet(clip: MotionClip, path, *, size=DEFAULT_SIZE, n_samples: int = SHEET_FRAMES,
                 mannequin=None) -> dict:
    """A PNG contact sheet: frames sampled along ``clip`` with the spoken word under each."""
    from PIL import Image, ImageDraw

    width, height = size
    frames = sheet_frames(clip.n_frames, n_samples)
    lay = sheet_layout(width, height, len(frames))
    own = mannequin is None
    m = mannequin or Mannequin(width, height)
    try:
        sheet = Image.new("RGB", lay["size"], overlay.WHITE)
        d = ImageDraw.Draw(sheet)
        s = overlay.scale(width, height)
        title = clip.text or "(no text)"
        if clip.speaker and clip.text:
            title = f"{clip.speaker}: {clip.text}"
        tf = overlay.font(max(9, round(15 * s)), bold=True)
        max_w = lay["size"][0] - 2 * max(4, round(8 * s))
        if d.textlength(title, font=tf) > max_w:
            while len(title) > 1 and d.textlength(title + "…", font=tf) > max_w:
                title = title[:-1]
            title += "…"
        d.text((max(4, round(8 * s)), lay["header"] / 2), title, font=tf, fill=overlay.INK, anchor="lm")
        panel = _Panel(m, clip, None)
        wf = overlay.font(max(9, round(17 * s)), bold=True)
        sf = overlay.font(max(8, round(12 * s)))
        for k, f in enumerate(frames):
            r, c = divmod(k, lay["cols"])
            x = c * width
            y = lay["header"] + r * (height + lay["caption"])
            sheet.paste(panel.image(f, word=False, legend=False), (x, y))
            word = overlay.word_at(clip.words, (f + 0.5) / FPS)
            cy = y + height
            d.text((x + width / 2, cy + lay["caption"] * 0.38), word or "—", font=wf,
                   fill=overlay.INK if word else overlay.SOFT_INK, anchor="mm")
            d.text((x + width / 2, cy + lay["caption"] * 0.80), f"frame {f} · {f / FPS:.2f} s", font=sf,
                   fill=overlay.SOFT_INK, anchor="mm")
            if c:
                d.line([(x, y), (x, cy + lay["caption"] - 1)], fill=overlay.TRACK, width=1)
        buf = io.BytesIO()
        sheet.save(buf, format="PNG", optimize=False)
        atomic_write(path, buf.getvalue())
        return {"frames": frames, "width": sheet.width, "height": sheet.height, "platform": m.platform}
    finally:
        if own:
            m.close()

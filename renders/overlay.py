"""Overlays drawn with Pillow on every frame: spoken word, control timeline, playhead, time, label.

Layout (``s = min(width, height) / 320``): the current word centred at the top; at the
bottom a thin timeline over the whole utterance with two lanes, pose controls in green
(upper lane) and style controls in red (lower lane) as in SGToolkit's Fig. 3, pauses in
grey, a dark playhead at the current frame, and the time in seconds above the lanes. A
picture's label (a speaker's name, A/B of a comparison) sits at the left under the band the
word's box can take (:func:`caption_bottom`), so that it never covers the word, whatever the
word and the size; it is cut short (…) where it would run into ``right`` (the face's close-up).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from core.skeleton import FPS

POSE_GREEN = (30, 168, 72)
STYLE_RED = (216, 44, 44)
PAUSE_GREY = (150, 156, 166)
TRACK = (206, 211, 218)
INK = (28, 32, 40)
SOFT_INK = (80, 88, 100)
WHITE = (255, 255, 255)
#: Colours every frame's palette must hold exactly.
FIXED_COLORS = (POSE_GREEN, STYLE_RED, PAUSE_GREY, TRACK, INK, SOFT_INK, WHITE)

_FONT_DIRS = ("/usr/share/fonts/truetype/dejavu", "/usr/share/fonts/dejavu", "/usr/share/fonts/TTF")


@lru_cache(maxsize=32)
def font(size: int, bold: bool = False):
    """DejaVu Sans when installed, else Pillow's built-in scalable font."""
    from pathlib import Path

    from PIL import ImageFont

    name = "DejaVuSans-Bold.ttf" if bold else "DejaVuSans.ttf"
    for d in _FONT_DIRS:
        p = Path(d) / name
        if p.exists():
            return ImageFont.truetype(str(p), size)
    return ImageFont.load_default(size=size)


def scale(width: int, height: int) -> float:
    return min(width, height) / 320.0


@dataclass(frozen=True)
class Timeline:
    """Where the timeline of a ``width`` x ``height`` frame lies, for ``n_frames`` frames."""

    left: int
    right: int
    pose_top: int
    pose_bottom: int
    style_top: int
    style_bottom: int
    n_frames: int

    def x(self, frame: float) -> float:
        return self.left + (self.right - self.left) * frame / max(self.n_frames, 1)

    @property
    def top(self) -> int:
        return self.pose_top


def timeline_geometry(width: int, height: int, n_frames: int) -> Timeline:
    s = scale(width, height)
    margin = max(4, round(12 * s))
    lane = max(3, round(5 * s))
    gap = max(1, round(2 * s))
    bottom = height - max(3, round(9 * s))
    return Timeline(left=margin, right=width - margin,
                    pose_top=bottom - 2 * lane - gap, pose_bottom=bottom - lane - gap,
                    style_top=bottom - lane, style_bottom=bottom, n_frames=n_frames)


def word_at(words, seconds: float) -> str | None:
    """The word being spoken at ``seconds`` (start <= t < end), or None."""
    for w in words or ():
        if w.start <= seconds < w.end:
            return w.word
    return None


def frame_word(words, frame: int) -> str | None:
    """The word frame ``frame`` is captioned with: the one being spoken at the frame's middle,
    ``(frame + 0.5) / FPS`` (the first in ``words`` when two are), or None between words. The
    page of ``sgt view`` has the same rule (``viewer/src/caption.js``)."""
    return word_at(words, (frame + 0.5) / FPS)


def draw_timeline(draw, width: int, height: int, frame: int, n_frames: int, controls, *, legend=True) -> None:
    g = timeline_geometry(width, height, n_frames)
    s = scale(width, height)
    draw.rectangle([g.left, g.pose_top, g.right - 1, g.style_bottom - 1], fill=TRACK)
    lanes = {"pose": (g.pose_top, g.pose_bottom, POSE_GREEN), "style": (g.style_top, g.style_bottom, STYLE_RED),
             "pause": (g.pose_top, g.style_bottom, PAUSE_GREY)}
    for kind in ("pause", "pose", "style"):  # later kinds paint over earlier ones
        top, bottom, color = lanes[kind]
        for c in controls or ():
            if c.kind != kind or c.end_frame <= c.start_frame:
                continue
            x0 = round(g.x(max(0, c.start_frame)))
            x1 = max(x0 + 1, round(g.x(min(n_frames, c.end_frame))))
            draw.rectangle([x0, top, x1 - 1, bottom - 1], fill=color)
    # Playhead.
    x = round(g.x(frame + 0.5))
    w = max(1, round(2 * s))
    reach = max(2, round(4 * s))
    draw.rectangle([x - w // 2, g.pose_top - reach, x - w // 2 + w - 1, g.style_bottom - 1 + min(reach, 2)], fill=INK)
    # Time, and a legend when there is room.
    small = font(max(8, round(12 * s)))
    t = frame / FPS
    text = f"{t:.2f} s"
    ty = g.pose_top - reach - max(1, round(2 * s))
    draw.text((g.right, ty), text, font=small, fill=INK, anchor="rb")
    if legend and s >= 0.7:
        draw.text((g.left, ty), "pose", font=small, fill=POSE_GREEN, anchor="lb")
        lw = draw.textlength("pose ", font=small)
        draw.text((g.left + lw, ty), "style", font=small, fill=STYLE_RED, anchor="lb")


def _word_style(width: int, height: int):
    """(font, padding, top) of the spoken word's box."""
    s = scale(width, height)
    return font(max(9, round(22 * s)), bold=True), max(2, round(6 * s)), max(2, round(8 * s))


def word_box(width: int, height: int, word: str | None) -> tuple[float, float, float, float] | None:
    """The box :func:`draw_word` draws behind ``word`` (x0, y0, x1, y1, corners included), None
    without a word."""
    if not word:
        return None
    f, pad, top = _word_style(width, height)
    x0, _, x1, y1 = f.getbbox(word, anchor="mt")
    cx = width / 2
    return (cx + x0 - pad, top, cx + x1 + pad, top + pad + y1 + pad)


def caption_bottom(width: int, height: int) -> int:
    """The lowest row the spoken word's box takes for any word the font's ascent and descent
    hold: what is drawn below it never meets the word."""
    f, pad, top = _word_style(width, height)
    ascent, descent = f.getmetrics()
    return top + pad + ascent + descent + pad


def draw_word(draw, width: int, height: int, word: str | None) -> None:
    box = word_box(width, height, word)
    if box is None:
        return
    f, pad, top = _word_style(width, height)
    draw.rounded_rectangle(box, radius=pad, fill=WHITE)
    draw.text((width / 2, top + pad), word, font=f, fill=INK, anchor="mt")


def fit(text: str, font, width: float) -> str:
    """``text``, cut short with "…" to take at most ``width`` pixels in ``font``."""
    if font.getlength(text) <= width:
        return text
    while len(text) > 1 and font.getlength(text + "…") > width:
        text = text[:-1]
    return text + "…"


@dataclass(frozen=True)
class Label:
    """Where a picture's label goes: its ``text`` (cut short to fit), drawn from ``origin`` (its
    left top) in ``font`` on ``box`` (x0, y0, x1, y1, corners included)."""

    text: str
    box: tuple[float, float, float, float]
    origin: tuple[float, float]
    font: object


def label_layout(width: int, height: int, label: str, *, word: str | None = None, right: float | None = None) -> Label:
    """The label of a ``width`` x ``height`` picture: at the left, under :func:`caption_bottom`
    (under ``word``'s own box too, should a glyph of it reach lower), ending before ``right``
    (default: as far from the right edge as it is from the left)."""
    s = scale(width, height)
    f = font(max(8, round(12 * s)), bold=True)
    pad = max(1, round(4 * s))
    box = word_box(width, height, word)
    y = max(caption_bottom(width, height), box[3] + 1 if box else 0) + max(2, round(4 * s))
    x = 2 * pad
    end = width - pad if right is None else right
    text = fit(label, f, max(1, end - 1 - pad - x))
    x0, _, x1, y1 = f.getbbox(text, anchor="lt")
    return Label(text, (x + x0 - pad, y, x + x1 + pad, y + pad + y1 + pad), (x, y + pad), f)


def draw_label(draw, width: int, height: int, label: str, *, color=INK, word: str | None = None,
               right: float | None = None) -> Label:
    """``label`` in white on a box of ``color`` where :func:`label_layout` puts it; returns its layout."""
    at = label_layout(width, height, label, word=word, right=right)
    draw.rectangle(at.box, fill=tuple(color))
    draw.text(at.origin, at.text, font=at.font, fill=WHITE, anchor="lt")
    return at


def decorate(image, frame: int, clip, *, label: str | None = None, word: bool = True, legend: bool = True):
    """Draw all overlays for ``frame`` of ``clip`` on PIL ``image`` (in place); returns it."""
    from PIL import ImageDraw

    d = ImageDraw.Draw(image)
    w, h = image.size
    n = clip.n_frames
    f = min(frame, n - 1)
    spoken = frame_word(clip.words, f) if word else None
    draw_word(d, w, h, spoken)
    draw_timeline(d, w, h, f, n, clip.controls, legend=legend)
    if label:
        draw_label(d, w, h, label, word=spoken)
    return image

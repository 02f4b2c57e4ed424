"""A streaming GIF89a writer: one global palette, looping, per-frame delays, no frame merging.

Pillow's multi-frame GIF writer keeps every frame in memory and merges identical
consecutive frames (adding their delays), which would change the frame count. This writer
assembles the container itself and uses Pillow only to LZW-compress each frame's pixels
(saved as a one-frame GIF and cut out of it). Every frame is written, cropped to the
rectangle that changed since the previous one (disposal "do not dispose").
"""

from __future__ import annotations

import io
import struct

import numpy as np

from core.skeleton import FPS


def frame_delays_cs(n_frames: int, fps: int = FPS) -> list[int]:
    """Per-frame delays in centiseconds whose running sum tracks i/fps to the nearest 10 ms.

    At 15 fps this is 7, 6, 7, 7, 6, 7, ...: every three frames last exactly 200 ms, and
    the total is ``round(n_frames * 100 / fps)`` centiseconds.
    """
    edges = [round(i * 100 / fps) for i in range(n_frames + 1)]
    return [b - a for a, b in zip(edges, edges[1:])]


def _lzw_blocks(indices: np.ndarray, palette_bytes: bytes) -> bytes:
    """The LZW-coded image data (min code size byte + sub-blocks + terminator) of ``indices``."""
    from PIL import Image

    im = Image.frombytes("P", (indices.shape[1], indices.shape[0]), np.ascontiguousarray(indices, dtype=np.uint8).tobytes())
    im.putpalette(palette_bytes)
    buf = io.BytesIO()
    im.save(buf, format="GIF", optimize=False, interlace=False)
    data = buf.getvalue()
    pos = 13
    flags = data[10]
    if flags & 0x80:
        pos += 3 * (2 ** ((flags & 7) + 1))
    while data[pos] == 0x21:  # skip extensions
        pos += 2
        while data[pos]:
            pos += data[pos] + 1
        pos += 1
    if data[pos] != 0x2C:
        raise ValueError("unexpected GIF layout from Pillow")
    iflags = data[pos + 9]
    pos += 10
    if iflags & 0x80:
        pos += 3 * (2 ** ((iflags & 7) + 1))
    start = pos
    pos += 1  # LZW minimum code size
    while data[pos]:
        pos += data[pos] + 1
    return data[start:pos + 1]


class GifWriter:
    """Add palette-index frames (H, W) uint8 one by one; :meth:`getvalue` gives the file."""

    def __init__(self, width: int, height: int, palette: bytes, loop: int = 0) -> None:
        if len(palette) != 768:
            raise ValueError("palette must have 256 RGB entries")
        self.width, self.height = int(width), int(height)
        self.palette = bytes(palette)
        self.n_frames = 0
        self._prev: np.ndarray | None = None
        self._out = io.BytesIO()
        out = self._out
        out.write(b"GIF89a")
        out.write(struct.pack("<HHBBB", self.width, self.height, 0xF7, 0, 0))  # global table, 256
        out.write(self.palette)
        out.write(b"!\xff\x0bNETSCAPE2.0\x03\x01" + struct.pack("<H", loop) + b"\x00")

    def add(self, indices: np.ndarray, delay_cs: int) -> None:
        idx = np.asarray(indices, dtype=np.uint8)
        if idx.shape != (self.height, self.width):
            raise ValueError(f"frame is {idx.shape}, expected {(self.height, self.width)}")
        if self._prev is None:
            x0, y0, x1, y1 = 0, 0, self.width, self.height
        else:
            diff = idx != self._prev
            rows = np.flatnonzero(diff.any(axis=1))
            if rows.size == 0:
                x0, y0, x1, y1 = 0, 0, 1, 1  # unchanged: still a frame of its own
            else:
                cols = np.flatnonzero(diff.any(axis=0))
                x0, y0, x1, y1 = int(cols[0]), int(rows[0]), int(cols[-1]) + 1, int(rows[-1]) + 1
        self._prev = idx
        out = self._out
        # Graphic control extension: disposal 1 (leave in place), delay, no transparency.
        out.write(b"!\xf9\x04" + bytes([1 << 2]) + struct.pack("<H", int(delay_cs)) + b"\x00\x00")
        out.write(b"," + struct.pack("<HHHHB", x0, y0, x1 - x0, y1 - y0, 0))
        out.write(_lzw_blocks(idx[y0:y1, x0:x1], self.palette))
        self.n_frames += 1

    def getvalue(self) -> bytes:
        return self._out.getvalue() + b";"


def build_palette(samples, fixed_colors=()) -> tuple[bytes, object]:
    """A 256-colour palette from RGB sample images (PIL) plus ``fixed_colors`` exactly.

    Returns (768 palette bytes, a PIL "P" image carrying it for ``Image.quantize``).
    """
    from PIL import Image

    samples = list(samples)
    w = max(s.width for s in samples)
    h = sum(s.height for s in samples)
    montage = Image.new("RGB", (w, h))
    y = 0
    for s in samples:
        montage.paste(s, (0, y))
        y += s.height
    n_free = 256 - len(fixed_colors)
    q = montage.quantize(colors=n_free, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    pal = list(q.getpalette()[: 3 * n_free])
    pal += [0] * (3 * n_free - len(pal))
    for c in fixed_colors:
        pal += list(c)
    palette = bytes(pal[:768])
    pimg = Image.new("P", (1, 1))
    pimg.putpalette(palette)
    return palette, pimg


def quantize(image, palette_image) -> np.ndarray:
    """RGB PIL image -> palette indices (H, W) uint8, nearest colour, no dithering."""
    from PIL import Image

    return np.asarray(image.quantize(palette=palette_image, dither=Image.Dither.NONE))

"""Per-frame number arrays as JSON text, one frame per line, written by numpy.

A motion file holds millions of numbers (poses, positions, hands of every utterance and of
every speaker's track). Turning each into a Python float and formatting it with ``repr``
took most of the time of writing a file (2.3 s for the 18 MB file of a 100-utterance
script). Here every number of an array is written with the same number of decimals and the
same width, so the text of every frame has the same layout: one template, the digits computed
for all numbers at once with integer arithmetic, scattered into the template's slots.

A number is padded on the left with spaces (JSON allows white space between tokens), so the
columns of a frame line up in a diff::

    [ 0.00163, 0.99999,-0.41224, 1.00000]

The values read back are those of ``numpy.round(array, decimals)``.
"""

from __future__ import annotations

import numpy as np

_SLOT = 1  # a placeholder byte in a template: never in JSON text


def _template(shape: tuple[int, ...], width: int) -> str:
    """The text of one frame of ``shape`` with each number a run of ``width`` slot bytes."""
    if not shape:
        return chr(_SLOT) * width
    inner = _template(shape[1:], width)
    return "[" + ",".join([inner] * shape[0]) + "]"


def frame_lines(array, decimals: int) -> list[str] | None:
    """The JSON text of each frame (first axis) of ``array``, every number rounded to
    ``decimals``; None when the array holds a value that is not a finite number (the caller
    writes it another way) or is empty."""
    a = np.asarray(array, dtype=np.float64)
    if a.ndim == 0 or a.shape[0] == 0 or a.size == 0 or not np.all(np.isfinite(a)):
        return None
    frames, per_frame = a.shape[0], a[0].size
    scaled = np.rint(a.reshape(frames, per_frame) * 10.0**decimals)
    if np.abs(scaled).max() >= 2.0**53:  # beyond exact integers in a float: let json write it
        return None
    value = scaled.astype(np.int64)
    magnitude = np.abs(value)
    whole = magnitude // 10**decimals
    int_digits = max(1, len(str(int(whole.max()))))
    width = 1 + int_digits + (1 + decimals if decimals > 0 else 0)  # sign, digits, point, decimals

    text = np.full((frames, per_frame, width), ord(" "), dtype=np.uint8)
    for j in range(decimals):
        text[..., width - decimals + j] = (magnitude // 10 ** (decimals - 1 - j)) % 10 + ord("0")
    if decimals > 0:
        text[..., 1 + int_digits] = ord(".")
    shown = np.ones_like(whole)  # how many digits the whole part shows (at least one)
    for place in range(int_digits - 1, -1, -1):
        column = 1 + int_digits - 1 - place
        digit = (whole // 10**place) % 10
        visible = (whole >= 10**place) | (place == 0)
        text[..., column] = np.where(visible, digit + ord("0"), ord(" "))
        if place > 0:
            shown += whole >= 10**place
    sign_at = int_digits - shown  # the column just before the first digit
    negative = value < 0
    rows, cols = np.nonzero(negative)
    text[rows, cols, sign_at[negative]] = ord("-")

    template = np.frombuffer(_template(a.shape[1:], width).encode("ascii"), dtype=np.uint8)
    slots = np.flatnonzero(template == _SLOT)
    lines = np.tile(template, (frames, 1))
    lines[:, slots] = text.reshape(frames, per_frame * width)
    joined = lines.tobytes().decode("ascii")
    step = len(template)
    return [joined[i * step : (i + 1) * step] for i in range(frames)]

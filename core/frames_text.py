"""Per-frame number arrays as JSON text, one frame per line, written by numpy.

A motion file holds millions of numbers (poses, positions, hands of every utterance and of
every speaker's track). Turning each into a Python float and formatting it with ``repr``
took most of the time of writing a file (2.3 s for the 18 MB file of a 100-utterance
script). Here every number of an array is written with the same number of decimals and the
same width, so the text of every frame has the same layout: one template, each number's text
looked up in tables (its sign and whole part, its decimals) for all numbers at once and
scattered into the template's slots. Whole parts of more than four digits are left to json.

A number is padded on the left with spaces (JSON allows white space between tokens), so the
columns of a frame line up in a diff::

    [ 0.00163, 0.99999,-0.41224, 1.00000]

The values read back are those of ``numpy.round(array, decimals)``.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from functools import lru_cache

import numpy as np

_SLOT = 1  # a placeholder byte in a template: never in JSON text


#: Whole parts of up to this many digits are looked up in a table (larger: json writes the array).
_MAX_TABLE_DIGITS = 4


@lru_cache(maxsize=8)
def _digit_texts(decimals: int) -> np.ndarray:
    """(10**decimals, decimals) bytes: each number's digits, zero-padded."""
    n = np.arange(10**decimals)
    return np.stack([(n // 10 ** (decimals - 1 - j)) % 10 + ord("0") for j in range(decimals)], axis=1).astype(np.uint8)


@lru_cache(maxsize=8)
def _whole_texts(digits: int) -> np.ndarray:
    """(2 * 10**digits, digits + 1) bytes: 0, 1, ... then -0, -1, ..., right-aligned in spaces."""
    texts = [str(i).rjust(digits + 1) for i in range(10**digits)]
    texts += [("-" + str(i)).rjust(digits + 1) for i in range(10**digits)]
    return np.frombuffer("".join(texts).encode("ascii"), dtype=np.uint8).reshape(-1, digits + 1)


def _template(shape: tuple[int, ...], width: int) -> str:
    """The text of one frame of ``shape`` with each number a run of ``width`` slot bytes."""
    if not shape:
        return chr(_SLOT) * width
    inner = _template(shape[1:], width)
    return "[" + ",".join([inner] * shape[0]) + "]"


@lru_cache(maxsize=64)
def _layout(shape: tuple[int, ...], width: int) -> tuple[np.ndarray, np.ndarray]:
    """The template of a frame (bytes) and where its numbers' bytes go."""
    template = np.frombuffer(_template(shape, width).encode("ascii"), dtype=np.uint8)
    return template, np.flatnonzero(template == _SLOT)


def frame_lines_of_many(arrays, decimals: int) -> list[list[str] | None]:
    """:func:`frame_lines` of each of ``arrays`` (all with the same shape after the first axis),
    formatted together (one pass, one column width for all); None for an array that
    :func:`frame_lines` cannot write on its own (then no array of the batch is formatted
    together)."""
    arrays = [np.asarray(a) for a in arrays]
    lengths = [len(a) for a in arrays]
    if not arrays or 0 in lengths or len({a.shape[1:] for a in arrays}) != 1:
        return [frame_lines(a, decimals) for a in arrays]
    lines = frame_lines(np.concatenate(arrays), decimals)
    if lines is None:
        return [frame_lines(a, decimals) for a in arrays]
    bounds = np.cumsum([0] + lengths)
    return [lines[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


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
    if int_digits > _MAX_TABLE_DIGITS:
        return None
    width = 1 + int_digits + (1 + decimals if decimals > 0 else 0)  # sign, digits, point, decimals
    text = np.empty((frames, per_frame, width), dtype=np.uint8)
    # the sign and the whole part, right-aligned, looked up; then the point and the decimals
    text[..., : 1 + int_digits] = _whole_texts(int_digits)[whole + (value < 0) * 10**int_digits]
    if decimals > 0:
        text[..., 1 + int_digits] = ord(".")
        text[..., 2 + int_digits :] = _digit_texts(decimals)[magnitude % 10**decimals]

    template, slots = _layout(a.shape[1:], width)
    lines = np.tile(template, (frames, 1))
    lines[:, slots] = text.reshape(frames, per_frame * width)
    joined = lines.tobytes().decode("ascii")
    step = len(template)
    return [joined[i * step : (i + 1) * step] for i in range(frames)]


_MARK = re.compile(r'"\\u0000lines(\d+)"')


def json_with_lines(doc, lines_of: Callable[[object], list[str] | None], *, ensure_ascii: bool = True) -> str:
    """``doc`` as JSON indented by one space, except each value for which ``lines_of`` gives a
    list of JSON texts: an array written one item per line (each item as given). Long arrays of
    small items (frames, a manifest's utterances) stay readable in a diff, and the json
    module's C encoder writes each item (``indent`` makes json use its pure-Python encoder)."""
    blocks: list[list[str]] = []

    def mark(x):
        lines = lines_of(x)
        if lines is not None:
            blocks.append(lines)
            return f"\0lines{len(blocks) - 1}"
        if isinstance(x, dict):
            return {k: mark(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [mark(v) for v in x]
        return x

    text = json.dumps(mark(doc), indent=1, ensure_ascii=ensure_ascii)

    def expand(m: re.Match) -> str:
        lines = blocks[int(m.group(1))]
        if not lines:
            return "[]"
        line = text[text.rfind("\n", 0, m.start()) + 1 : m.start()]
        pad = "\n" + " " * (len(line) - len(line.lstrip(" ")))
        return "[" + pad + " " + ("," + pad + " ").join(lines) + pad + "]"

    return _MARK.sub(expand, text)

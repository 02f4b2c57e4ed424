"""Small signal helpers: WAV encoding, voiced-region detection and silence insertion.

All functions take mono ``numpy`` arrays (int16 or float) and work in *samples*.
"""

from __future__ import annotations

import io
import wave
from typing import Sequence

import numpy as np

#: Analysis frame for energy detection, seconds.
FRAME_S = 0.005
#: A frame is "voiced" when its RMS exceeds this fraction of the loudest frame's RMS (-34 dB).
VOICED_REL = 0.02


def wav_bytes(samples: np.ndarray, sample_rate: int) -> bytes:
    """Encode mono samples as a 16-bit PCM WAV (floats are taken as -1..1). Deterministic."""
    if samples.dtype != np.int16:
        samples = np.clip(np.round(np.asarray(samples, dtype=np.float64) * 32767.0), -32768, 32767)
        samples = samples.astype(np.int16)
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(int(sample_rate))
        w.writeframes(samples.astype("<i2").tobytes())
    return buf.getvalue()


def frame_rms(samples: np.ndarray, sample_rate: int) -> tuple[np.ndarray, int]:
    """RMS per analysis frame and the frame length in samples."""
    hop = max(1, int(round(sample_rate * FRAME_S)))
    n = len(samples) // hop
    x = np.asarray(samples[: n * hop], dtype=np.float64).reshape(n, hop) if n else np.zeros((0, hop))
    rms = np.sqrt((x * x).mean(axis=1)) if n else np.zeros(0)
    if len(samples) > n * hop:  # partial last frame
        tail = np.asarray(samples[n * hop :], dtype=np.float64)
        rms = np.append(rms, np.sqrt((tail * tail).mean()))
    return rms, hop


def voiced_mask(samples: np.ndarray, sample_rate: int) -> tuple[np.ndarray, int]:
    rms, hop = frame_rms(samples, sample_rate)
    if len(rms) == 0:
        return np.zeros(0, dtype=bool), hop
    peak = float(rms.max())
    floor = 1e-4 if samples.dtype.kind == "f" else 3.0  # absolute floor: digital silence is never voiced
    return rms > max(peak * VOICED_REL, floor), hop


def voiced_bounds(mask: np.ndarray, hop: int, n_samples: int) -> tuple[int, int] | None:
    """(first voiced sample, end of last voiced frame) or None when all silent."""
    idx = np.flatnonzero(mask)
    if len(idx) == 0:
        return None
    return int(idx[0]) * hop, min(n_samples, (int(idx[-1]) + 1) * hop)


def voiced_end_in(mask: np.ndarray, hop: int, lo: int, hi: int) -> int:
    """End (sample) of the last voiced frame starting in [lo, hi - hop]; ``lo`` if none is voiced."""
    f_lo, f_hi = lo // hop, min(len(mask), hi // hop)
    idx = np.flatnonzero(mask[f_lo:f_hi])
    if len(idx) == 0:
        return lo
    return max(lo, min(hi, (f_lo + int(idx[-1]) + 1) * hop))


def quiet_cut(samples: np.ndarray, sample_rate: int, lo: int, hi: int) -> int:
    """A sample index in [lo, hi] where inserting silence is least audible.

    Picks the quietest analysis frame in the window (the latest one on ties) and, inside it,
    the sample with the smallest magnitude.
    """
    lo = max(0, min(lo, len(samples)))
    hi = max(lo, min(hi, len(samples)))
    if hi - lo < 2:
        return hi
    seg = np.abs(np.asarray(samples[lo:hi], dtype=np.float64))
    hop = max(1, int(round(sample_rate * FRAME_S)))
    n = max(1, len(seg) // hop)
    energies = [float(seg[i * hop : (i + 1) * hop].mean()) if i < n - 1 else float(seg[i * hop :].mean())
                for i in range(n)]
    best = min(range(n), key=lambda i: (energies[i], -i))
    a = lo + best * hop
    b = hi if best == n - 1 else a + hop
    window = np.abs(np.asarray(samples[a:b], dtype=np.float64))
    # latest minimum so that a word onset is never split off
    j = len(window) - 1 - int(np.argmin(window[::-1]))
    return a + j


def insert_silences(samples: np.ndarray, cuts: Sequence[tuple[int, int]]) -> np.ndarray:
    """Insert ``n`` zero samples before sample index ``pos`` for each ``(pos, n)`` (positions in the input).

    A short linear fade (2 ms at 22 kHz: 44 samples) on each side of a cut avoids clicks
    when the cut is not at a zero crossing.
    """
    if not cuts:
        return samples
    x = np.asarray(samples)
    pieces = []
    prev = 0
    fade = 44
    for pos, n in sorted(cuts):
        piece = x[prev:pos].copy()
        if n > 0 and len(piece) and abs(float(piece[-1])) > 0:
            k = min(fade, len(piece))
            ramp = np.linspace(1.0, 0.0, k + 1)[1:]
            piece[-k:] = (piece[-k:].astype(np.float64) * ramp).astype(x.dtype)
        pieces.append(piece)
        pieces.append(np.zeros(int(n), dtype=x.dtype))
        prev = pos
    pieces.append(x[prev:].copy())
    out = np.concatenate(pieces)
    # fade-ins after each inserted block
    offset = 0
    for pos, n in sorted(cuts):
        offset += n
        start = pos + offset
        if n > 0 and start < len(out):
            k = min(fade, len(out) - start)
            ramp = np.linspace(0.0, 1.0, k + 1)[1:]
            out[start : start + k] = (out[start : start + k].astype(np.float64) * ramp).astype(x.dtype)
    return out

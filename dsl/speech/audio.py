"""Small signal helpers: WAV encoding, voiced-region detection and silence insertion.

All functions take mono ``numpy`` arrays (int16 or float) and work in *samples*.
"""

from __future__ import annotations

import io
import math
import wave
from functools import lru_cache
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


def read_wav(path) -> tuple[np.ndarray, int] | None:
    """(float32 samples (n, channels) in -1..1, sample rate) of a 16-bit PCM WAV file, read with
    the standard library (the same numbers as ``soundfile.read(dtype="float32")``); None for any
    other kind of file, which the caller reads with soundfile."""
    got = wav_blocks(path)
    if got is None:
        return None
    blocks, rate = got
    parts = list(blocks)
    return (np.concatenate(parts) if len(parts) != 1 else parts[0]), rate


#: Frames :func:`wav_blocks` reads at a time.
WAV_BLOCK = 1 << 16


def wav_blocks(path, frames: int = WAV_BLOCK):
    """:func:`read_wav`'s samples ``frames`` at a time: (an iterator of float32 (k, channels)
    blocks, sample rate), or None for a file that is no 16-bit PCM WAV. The file stays open
    until the iterator is used up (or dropped)."""
    try:
        w = wave.open(str(path), "rb")  # noqa: SIM115 (closed by the blocks' generator, or below)
    except (wave.Error, EOFError):
        return None
    try:
        ok = w.getsampwidth() == 2 and w.getcomptype() == "NONE"
        channels, rate = w.getnchannels(), w.getframerate()
    except BaseException:
        w.close()
        raise
    if not ok:
        w.close()
        return None

    def blocks():
        with w:
            while True:
                try:
                    raw = w.readframes(frames)
                except (wave.Error, EOFError):
                    return
                data = np.frombuffer(raw, "<i2")[: len(raw) // (2 * channels) * channels]
                if not len(data):
                    return
                yield (data.astype(np.float32) / 32768.0).reshape(-1, channels)

    return blocks(), rate


@lru_cache(maxsize=8)
def _polyphase(up: int, down: int) -> tuple[np.ndarray, int, int]:
    """scipy's resample_poly filter for ``up / down`` (reduced) as a bank: (bank (up, per_phase),
    first, per_phase), bank[phase, -1 - l] = h[phase + l up]."""
    max_rate = max(up, down)
    half_len = 10 * max_rate
    taps = 2 * half_len + 1
    m = np.arange(taps) - half_len
    h = np.sinc(m / max_rate) / max_rate * np.kaiser(taps, 5.0)
    h = h / h.sum() * up
    pre = down - half_len % down  # scipy's alignment: zeros before the filter, then whole outputs dropped
    h = np.concatenate([np.zeros(pre), h])
    first = (half_len + pre) // down
    per_phase = -(-len(h) // up)
    bank = np.pad(h, (0, per_phase * up - len(h))).reshape(per_phase, up).T[:, ::-1]
    return np.ascontiguousarray(bank), first, per_phase


def resample_poly(x: np.ndarray, up: int, down: int) -> np.ndarray:
    """Resample by ``up / down`` with a polyphase filter: the same numbers as
    ``scipy.signal.resample_poly(x, up, down)`` with its defaults (a Kaiser-windowed sinc with
    beta 5 and 10 zero crossings per side; tests/test_resample.py compares them), in float64,
    without importing scipy.signal (about 1 s of imports)."""
    g = math.gcd(int(up), int(down))
    up, down = int(up) // g, int(down) // g
    x = np.asarray(x, np.float64)
    if up == down == 1:
        return x.copy()
    n_in = len(x)
    n_out = -(-n_in * up // down)
    bank, first, per_phase = _polyphase(up, down)
    # Output k is input sample (k + first) * down // up filtered by the phase (k + first) * down % up
    # of the filter. Outputs k = r, r + up, r + 2 up... share a phase and read inputs ``down``
    # apart: each such class is one strided view of the input times one row of the bank, summed
    # by numpy in the same order whatever the length (the stream resamples in pieces with it).
    last = (n_out - 1 + first) * down // up + per_phase  # one past the last input any output reads
    xp = np.concatenate([np.zeros(per_phase - 1), x, np.zeros(max(0, last - n_in - per_phase + 1))])
    out = np.empty(n_out)
    step = xp.strides[0]
    for r in range(min(up, n_out)):
        count = -(-(n_out - r) // up)
        start, phase = divmod((r + first) * down, up)
        rows = np.ndarray((count, per_phase), np.float64, xp, start * step, (down * step, step))  # a view
        out[r::up] = np.einsum("kl,l->k", rows, bank[phase])
    return out


class StreamResampler:
    """:func:`resample_poly` of audio that arrives in pieces: :meth:`push` each piece and get
    the output samples that no later input can change; :meth:`flush` at the end gives the rest.
    All pieces together give exactly the numbers of one :func:`resample_poly` call on the whole
    audio (tests/test_resample.py checks). Memory stays bounded: input is kept only
    while an output still needs it."""

    def __init__(self, rate_in: int, rate_out: int) -> None:
        g = math.gcd(int(rate_in), int(rate_out))
        self.up, self.down = int(rate_out) // g, int(rate_in) // g
        # how far (input samples) the filter reaches on each side of an output's position
        self.reach = (10 * max(self.up, self.down)) // self.up + 2
        self.buffer = np.zeros(0, np.float64)
        self.base = 0  # input index of buffer[0]; a multiple of ``down``, so outputs stay aligned
        self.done = 0  # outputs given so far
        self.total_in = 0

    def push(self, samples) -> np.ndarray:
        self.buffer = np.concatenate([self.buffer, np.asarray(samples, np.float64)])
        self.total_in += len(samples)
        # output j sits at input j * down / up and is final once the input reaches past it by ``reach``
        final = max(self.done, (self.total_in - self.reach) * self.up // self.down)
        return self._take(final)

    def flush(self) -> np.ndarray:
        """The outputs left, up to the length :func:`resample_poly` gives the whole input."""
        return self._take(-(-self.total_in * self.up // self.down))

    def _take(self, end: int) -> np.ndarray:
        if end <= self.done:
            return np.zeros(0, np.float64)
        first = self.base * self.up // self.down  # the output at buffer[0]
        out = resample_poly(self.buffer, self.up, self.down)[self.done - first : end - first]
        self.done = end
        # keep the input that outputs from ``done`` on read (from reach before the next one)
        keep = max(self.base, (self.done * self.down // self.up - 2 * self.reach) // self.down * self.down)
        self.buffer, self.base = self.buffer[keep - self.base :], keep
        return out


#: Voice activity in recordings: a stretch is voice when it rises this far above the noise
#: floor (dB) and extends while it stays this far above it (hysteresis); see :func:`voice_activity`.
VOICE_ON_DB, VOICE_OFF_DB = 12.0, 6.0


def voice_activity(samples: np.ndarray, sample_rate: int) -> tuple[np.ndarray, int]:
    """Voiced frames of a recording (energy VAD, :data:`FRAME_S` frames) and the frame length.

    Unlike :func:`voiced_mask` (for synthesized speech, whose silence is digital) it allows
    for room noise: the noise floor is the 10th percentile of the frames' RMS; a stretch is
    voice where the RMS rises :data:`VOICE_ON_DB` above that floor (and above the -34 dB of
    :data:`VOICED_REL` below the loudest frame) and it extends to the frames around it that
    stay :data:`VOICE_OFF_DB` above the floor (and above -40 dB)."""
    rms, hop = frame_rms(samples, sample_rate)
    if len(rms) == 0:
        return np.zeros(0, dtype=bool), hop
    peak = float(rms.max())
    digital = 1e-4 if samples.dtype.kind == "f" else 3.0
    noise = float(np.percentile(rms, 10))
    on = max(peak * VOICED_REL, noise * 10 ** (VOICE_ON_DB / 20), digital)
    off = max(peak * VOICED_REL / 2, noise * 10 ** (VOICE_OFF_DB / 20), digital)
    weak = rms > off
    mask = np.zeros(len(rms), dtype=bool)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], weak.astype(np.int8), [0]])))
    for a, b in zip(edges[::2], edges[1::2]):
        if (rms[a:b] > on).any():
            mask[a:b] = True
    return mask, hop

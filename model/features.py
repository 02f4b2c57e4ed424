"""Speech features per motion frame: the one place that turns audio and words into model input.

- Audio (Kucherenko et al. 4.2; SGToolkit uses raw audio through a CNN): ``N_MELS`` log-mel
  bands plus log energy, one vector per motion frame (``FPS`` = 15 per second, window of two
  frames centred on the frame). Levels are relative to the utterance's **speech level**: per
  band, the power is divided by its level over the utterance's loud frames
  (:func:`speech_level`), a floor ``FLOOR_DB`` below that level is added, and the log is
  scaled by fixed constants (:func:`level_features`). So gain and microphone colour do not
  matter (real recordings versus TTS), and silence reads the same whatever its share of the
  utterance: digital zeros sit exactly on the floor (:func:`silence_features`), room noise a
  little above it. (A per-utterance z-score, used before, moved every value with the share
  of silence and put digital zeros many deviations below anything seen in training; the
  generator then gestured wildly inside a ``[pause 2s]``.)
- Words: the word spoken at each frame as a hashed id in [1, WORD_BUCKETS) (0 = no word), so
  any word, seen in training or not, has an embedding slot; plus a word-onset flag.

The log-mel and energy are computed with numpy (a short-time Fourier transform with a periodic
Hann window and zero padding, the Slaney mel scale and filter normalisation, frame RMS): the
same numbers as ``librosa.feature.melspectrogram`` and ``librosa.feature.rms`` with these
settings (a test compares them), without librosa's ~1.5 s of imports and numba compilation
on the first call of every process.
"""

from __future__ import annotations

import threading
import zlib
from collections import OrderedDict
from functools import lru_cache
from pathlib import Path

import numpy as np

from core import cancel
from core.skeleton import FPS
from dsl.speech.audio import StreamResampler, wav_blocks

SAMPLE_RATE = 16000
N_MELS = 32
AUDIO_DIM = N_MELS + 1
WORD_BUCKETS = 4096
HOP = SAMPLE_RATE // FPS  # samples per motion frame
#: What the audio numbers mean; weights files record it, so weights trained on other audio
#: features are refused (v1: per-utterance z-scores; v2: levels relative to the speech level).
AUDIO_FEATURES = "log-mel+energy, dB re speech level, floor -60 dB (v2)"


#: Frames of a recording :func:`load_audio` reads and resamples at a time.
AUDIO_BLOCK = 1 << 16


def load_audio(path: Path | str, sample_rate: int = SAMPLE_RATE) -> np.ndarray:
    """Mono float32 audio at ``sample_rate``. 16-bit WAV (what espeak-ng writes) is read with the
    standard library, anything else with soundfile; resampling is numpy's (no scipy import).
    The file is read, mixed down and resampled :data:`AUDIO_BLOCK` frames at a time
    (:class:`dsl.speech.audio.StreamResampler`: the numbers of one :func:`resample_poly` of the
    whole), so memory holds the result and a block, not the file's samples in float64."""
    blocks, sr = wav_blocks(path, AUDIO_BLOCK) or _soundfile_blocks(path)
    resampler = StreamResampler(int(sr), sample_rate) if sr != sample_rate else None
    out = []
    for block in blocks:
        cancel.check()
        mono = block.mean(axis=1)
        out.append(mono if resampler is None else resampler.push(mono).astype(np.float32))
    if resampler is not None:
        out.append(resampler.flush().astype(np.float32))
    return np.concatenate(out) if out else np.zeros(0, np.float32)


def _soundfile_blocks(path):
    """(float32 (k, channels) blocks, sample rate) of any file soundfile reads."""
    import soundfile as sf

    f = sf.SoundFile(str(path))

    def blocks():
        with f:
            yield from f.blocks(blocksize=AUDIO_BLOCK, dtype="float32", always_2d=True)

    return blocks(), f.samplerate


N_FFT = max(2 * HOP, 512)  # STFT size and window length: two motion frames


def _hz_to_mel(f):
    """Slaney's mel scale: linear below 1 kHz, logarithmic above."""
    f = np.asarray(f, np.float64)
    lin = f / (200.0 / 3)
    log = 15.0 + np.log(np.maximum(f, 1e-10) / 1000.0) / (np.log(6.4) / 27.0)
    return np.where(f >= 1000.0, log, lin)


def _mel_to_hz(m):
    m = np.asarray(m, np.float64)
    lin = m * (200.0 / 3)
    log = 1000.0 * np.exp((np.log(6.4) / 27.0) * (m - 15.0))
    return np.where(m >= 15.0, log, lin)


@lru_cache(maxsize=1)
def _analysis() -> tuple[np.ndarray, tuple[tuple[int, int, np.ndarray], ...]]:
    """The STFT window (periodic Hann) and each mel filter as (first bin, end bin, its weights there)."""
    window = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(N_FFT) / N_FFT)
    bands = []
    for row in _mel_filters():
        bins = np.flatnonzero(row)
        lo, hi = int(bins[0]), int(bins[-1]) + 1
        bands.append((lo, hi, row[lo:hi].astype(np.float32)))
    return window.astype(np.float32), tuple(bands)


def _mel_filters(sr: int = SAMPLE_RATE, n_fft: int = N_FFT, n_mels: int = N_MELS) -> np.ndarray:
    """(n_mels, n_fft // 2 + 1) triangular filters, area-normalised (Slaney), 0 Hz to sr / 2."""
    freqs = np.fft.rfftfreq(n_fft, 1.0 / sr)
    edges = _mel_to_hz(np.linspace(_hz_to_mel(0.0), _hz_to_mel(sr / 2.0), n_mels + 2))
    width = np.diff(edges)
    ramps = edges[:, None] - freqs[None, :]
    rise = -ramps[:-2] / width[:-1, None]
    fall = ramps[2:] / width[1:, None]
    weights = np.maximum(0.0, np.minimum(rise, fall))
    return weights * (2.0 / (edges[2:] - edges[:-2]))[:, None]


#: Motion frames whose powers :func:`frame_powers` computes at a time: the spectrum takes about
#: 40 KB a frame, so the memory stays the same for an utterance of any length.
CHUNK_FRAMES = 1024


def frame_powers(audio: np.ndarray, first: int, count: int) -> np.ndarray:
    """(count, AUDIO_DIM) float64 powers of motion frames ``first``, ``first + 1``, ... of
    ``audio`` at SAMPLE_RATE: the mel bands, then the mean square. Frame k is centred on sample
    ``k * HOP`` and spans ``2 * HOP`` samples (:data:`N_FFT`); samples outside the audio are 0.
    Any run of frames gives the numbers the whole audio gives them (the stream relies on it),
    so they are computed :data:`CHUNK_FRAMES` at a time."""
    if count <= CHUNK_FRAMES:
        return _frame_powers(audio, first, count)
    out = np.empty((count, AUDIO_DIM), np.float64)
    for a in range(0, count, CHUNK_FRAMES):
        cancel.check()
        out[a : a + CHUNK_FRAMES] = _frame_powers(audio, first + a, min(CHUNK_FRAMES, count - a))
    return out


def _frame_powers(audio: np.ndarray, first: int, count: int) -> np.ndarray:
    y = np.asarray(audio, np.float32)
    lo, hi = (first - 1) * HOP, (first + count) * HOP
    segment = np.zeros(hi - lo, np.float32)
    a, b = max(lo, 0), min(hi, len(y))
    if b > a:
        segment[a - lo : b - lo] = y[a:b]
    frames = np.lib.stride_tricks.sliding_window_view(segment, N_FFT)[::HOP][:count]
    window, bands = _analysis()
    power = np.abs(np.fft.rfft(frames * window, axis=1)) ** 2
    # Each band sums its own bins with numpy's loops, not a BLAS matrix product: BLAS sums
    # differ with its thread count (measured: 1e-6 between 1 and 2 OpenBLAS threads), and the
    # features must be the same bits in a worker process, a build and the corpus on any machine.
    out = np.empty((count, len(bands) + 1), np.float64)
    for m, (lo_bin, hi_bin, weights) in enumerate(bands):
        out[:, m] = np.einsum("tf,f->t", power[:, lo_bin:hi_bin], weights)
    out[:, -1] = np.mean(frames.astype(np.float64) ** 2, axis=1)
    return out


def raw_features(audio: np.ndarray, n_frames: int, offset_frames: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(mel power (n_frames, N_MELS), frame energy (n_frames,) = mean square) of ``audio`` at
    SAMPLE_RATE placed ``offset_frames`` into the motion; silence before the offset and past
    the end. The same numbers as ``librosa.feature.melspectrogram`` and ``rms ** 2``."""
    powers = frame_powers(audio, -offset_frames, n_frames)
    return powers[:, :N_MELS], powers[:, N_MELS]


#: The speech level of a band: this percentile of its power over the utterance's active frames,
#: those within ACTIVE_DB of the band's loudest frame (silence and quiet noise are left out, so
#: the level does not depend on how much of the utterance is silent).
LEVEL_PERCENTILE = 90.0
ACTIVE_DB = 30.0
#: The floor, in dB below the speech level: digital silence reads exactly this.
FLOOR_DB = 60.0
#: Power below this (absolute) is taken as no signal at all when finding the speech level.
_NO_SIGNAL = 1e-12
#: Fixed scaling of the log levels: speech reads about 0 to 1, the floor -2.
_DB_SCALE, _DB_OFFSET = 20.0, 1.0


def speech_level(power: np.ndarray) -> np.ndarray:
    """(1, bands): per column, the :data:`LEVEL_PERCENTILE`-th percentile of the frames within
    :data:`ACTIVE_DB` of the column's maximum (at least a tiny absolute level)."""
    p = np.asarray(power, np.float64)
    top = np.maximum(p.max(axis=0, keepdims=True), _NO_SIGNAL)
    active = np.where(p >= top * 10.0 ** (-ACTIVE_DB / 10.0), p, np.nan)
    # a column of digital silence has no active frame: NaN, then the floor
    return np.fmax(nan_percentile(active, LEVEL_PERCENTILE), _NO_SIGNAL)


def nan_percentile(values: np.ndarray, q: float) -> np.ndarray:
    """(1, columns): ``np.nanpercentile(values, q, axis=0, keepdims=True)`` (linear), the same
    bits (tests/test_features.py compares them), NaN for a column without numbers; vectorised
    (numpy's runs a Python function per column: 4 ms a call, which a stream makes per frame)."""
    ordered = np.sort(values, axis=0)  # NaN last
    n = np.count_nonzero(~np.isnan(values), axis=0)
    index = (n - 1) * (q / 100.0)
    lo = np.floor(index).astype(np.int64).clip(0)
    hi = np.minimum(lo + 1, np.maximum(n - 1, 0))
    t = index - lo
    columns = np.arange(values.shape[1])
    a, b = ordered[lo, columns], ordered[hi, columns]
    diff = b - a
    out = np.where(t >= 0.5, b - diff * (1 - t), a + diff * t)  # numpy's _lerp
    return np.where(n > 0, out, np.nan)[None]


def level_features(power: np.ndarray, level: np.ndarray | None = None) -> np.ndarray:
    """Per column (band): ``10 log10(p / L + 10^(-FLOOR_DB / 10)) / 20 + 1`` with ``L`` the
    column's :func:`speech_level` (of ``power``, or ``level`` when given: a stream knows only
    the speech so far). Speech reads about 0 to 1, silence the floor, -2."""
    p = np.asarray(power, np.float64)
    if level is None:
        level = speech_level(p)
    db = 10.0 * np.log10(p / level + 10.0 ** (-FLOOR_DB / 10.0))
    return db / _DB_SCALE + _DB_OFFSET


def level_db(features: np.ndarray) -> np.ndarray:
    """The features back in dB relative to the speech level (the inverse of the scaling)."""
    return (np.asarray(features, np.float64) - _DB_OFFSET) * _DB_SCALE


def audio_features(audio: np.ndarray, n_frames: int, offset_frames: int = 0) -> np.ndarray:
    """(n_frames, AUDIO_DIM) float32 for ``audio`` at SAMPLE_RATE placed ``offset_frames`` into the motion.

    Frames before the offset or past the end of the audio get the features of silence.
    """
    mel, rms2 = raw_features(audio, n_frames, offset_frames)
    return level_features(np.concatenate([mel, rms2[:, None]], axis=1)).astype(np.float32)


def silence_features(n_frames: int) -> np.ndarray:
    """The features of ``n_frames`` of silence (no audio at all): every value on the floor."""
    return np.full((n_frames, AUDIO_DIM), -FLOOR_DB / _DB_SCALE + _DB_OFFSET, np.float32)


def word_id(word: str) -> int:
    """Stable hashed id of a word in [1, WORD_BUCKETS)."""
    w = word.lower().replace("\u2019", "'")
    return 1 + zlib.crc32(w.encode("utf-8")) % (WORD_BUCKETS - 1)


def word_features(words, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(ids (T,) int64, onsets (T,) float32) from :class:`~core.words.TimedWord` (seconds)."""
    ids = np.zeros(n_frames, np.int64)
    onsets = np.zeros(n_frames, np.float32)
    for w in words:
        text, start, end = w
        a = int(np.floor(start * FPS + 1e-6))
        b = max(a + 1, int(np.ceil(end * FPS - 1e-6)))
        if 0 <= a < n_frames:
            onsets[a] = 1.0
        ids[max(0, a) : max(0, min(n_frames, b))] = word_id(text)
    return ids, onsets


def speech_inputs(inputs, n_frames: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(audio features, word ids, onsets) of an engine's inputs (:class:`model.generate.EngineInputs`:
    its speech audio, starting ``lead_in`` seconds in, and its timed words) on the motion
    timeline of ``n_frames``; silence features when there is no audio file. A speech file's
    features are computed once (:data:`FEATURE_CACHE`): the same line again (a service's
    speech cache gives it the same file) skips reading, resampling and the spectrum."""
    audio = None
    if inputs.audio_path is not None:
        offset = int(round(inputs.lead_in * FPS))  # noqa: RUF046  (lead_in may be a numpy float32)
        try:
            st = Path(inputs.audio_path).stat()
        except OSError:  # no such file: silence, as before there was speech
            st = None
        if st is not None:
            key = (str(inputs.audio_path), st.st_ino, st.st_size, st.st_mtime_ns, n_frames, offset)
            audio = FEATURE_CACHE.get(key)
            if audio is None:
                audio = audio_features(load_audio(inputs.audio_path), n_frames, offset_frames=offset)
                FEATURE_CACHE.put(key, audio)
    if audio is None:
        audio = silence_features(n_frames)
    ids, onsets = word_features(inputs.words, n_frames)
    return audio, ids, onsets


class FeatureCache:
    """The audio features of the speech files used last, at most ``budget`` bytes of them (the
    least recently used go first). Keyed by the file's path, inode, size and modification time
    and the timeline (frames, offset), so a changed file is read again. Thread-safe (a
    service's worker threads share it); gives copies (an engine may change its array)."""

    def __init__(self, budget: int) -> None:
        self.budget = budget
        self.used = 0
        self.items: OrderedDict = OrderedDict()
        self.lock = threading.Lock()

    def get(self, key) -> np.ndarray | None:
        with self.lock:
            features = self.items.get(key)
            if features is None:
                return None
            self.items.move_to_end(key)
            return features.copy()

    def put(self, key, features: np.ndarray) -> None:
        if features.nbytes > self.budget:
            return
        with self.lock:
            if key in self.items:
                return
            self.items[key] = features.copy()
            self.used += features.nbytes
            while self.used > self.budget:
                _, old = self.items.popitem(last=False)
                self.used -= old.nbytes


#: Speech features of recent files: 16 MiB holds about 2 hours of speech (132 bytes a frame),
#: some 1,700 five-second lines.
FEATURE_CACHE = FeatureCache(16 << 20)

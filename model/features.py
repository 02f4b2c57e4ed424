"""Speech features per motion frame: the one place that turns audio and words into model input.

- Audio (Kucherenko et al. 4.2; SGToolkit uses raw audio through a CNN): ``N_MELS`` log-mel
  bands plus log energy, one vector per motion frame (``FPS`` = 15 per second, window of two
  frames centred on the frame). Each utterance is normalised to zero mean and unit variance
  per band, so gain and microphone colour do not matter (real recordings versus TTS).
- Words: the word spoken at each frame as a hashed id in [1, WORD_BUCKETS) (0 = no word), so
  any word, seen in training or not, has an embedding slot; plus a word-onset flag.

librosa is imported only when audio features are computed.
"""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

from model.skeleton import FPS

SAMPLE_RATE = 16000
N_MELS = 32
AUDIO_DIM = N_MELS + 1
WORD_BUCKETS = 4096
HOP = SAMPLE_RATE // FPS  # samples per motion frame


def load_audio(path: Path | str, sample_rate: int = SAMPLE_RATE) -> np.ndarray:
    """Mono float32 audio at ``sample_rate``."""
    import soundfile as sf

    data, sr = sf.read(str(path), dtype="float32", always_2d=True)
    mono = data.mean(axis=1)
    if sr != sample_rate:
        from scipy.signal import resample_poly

        g = np.gcd(int(sr), int(sample_rate))
        mono = resample_poly(mono, sample_rate // g, int(sr) // g).astype(np.float32)
    return mono


def audio_features(audio: np.ndarray, n_frames: int, offset_frames: int = 0) -> np.ndarray:
    """(n_frames, AUDIO_DIM) float32 for ``audio`` at SAMPLE_RATE placed ``offset_frames`` into the motion.

    Frames before the offset or past the end of the audio get the features of silence.
    """
    import librosa

    pad = np.zeros(offset_frames * HOP, np.float32)
    y = np.concatenate([pad, np.asarray(audio, np.float32)])
    need = n_frames * HOP
    y = np.pad(y, (0, max(0, need - len(y))))[:need]
    mel = librosa.feature.melspectrogram(y=y, sr=SAMPLE_RATE, n_fft=2 * HOP if 2 * HOP >= 512 else 512,
                                         hop_length=HOP, win_length=2 * HOP, n_mels=N_MELS, center=True)
    logmel = np.log(mel + 1e-6)[:, :n_frames]
    energy = np.log((librosa.feature.rms(y=y, frame_length=2 * HOP, hop_length=HOP, center=True) ** 2) + 1e-8)[:, :n_frames]
    feats = np.concatenate([logmel, energy], axis=0).T  # (T, AUDIO_DIM)
    if len(feats) < n_frames:
        feats = np.pad(feats, ((0, n_frames - len(feats)), (0, 0)), mode="edge")
    mean = feats.mean(axis=0, keepdims=True)
    std = feats.std(axis=0, keepdims=True) + 1e-3
    return ((feats - mean) / std).astype(np.float32)


def word_id(word: str) -> int:
    """Stable hashed id of a word in [1, WORD_BUCKETS)."""
    w = word.lower().replace("\u2019", "'")
    return 1 + zlib.crc32(w.encode("utf-8")) % (WORD_BUCKETS - 1)


def word_features(words, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(ids (T,) int64, onsets (T,) float32) from words with ``word``, ``start``, ``end`` seconds."""
    ids = np.zeros(n_frames, np.int64)
    onsets = np.zeros(n_frames, np.float32)
    for w in words:
        text, start, end = (w["word"], w["start"], w["end"]) if isinstance(w, dict) else (w[0], w[1], w[2])
        a = int(np.floor(start * FPS + 1e-6))
        b = max(a + 1, int(np.ceil(end * FPS - 1e-6)))
        if 0 <= a < n_frames:
            onsets[a] = 1.0
        ids[max(0, a) : max(0, min(n_frames, b))] = word_id(text)
    return ids, onsets

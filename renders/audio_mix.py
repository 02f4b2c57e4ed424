"""The speech of a performance as one signal: every utterance's audio at its place on the
performance clock, so that sample 0 plays with motion frame 0.

An utterance's audio starts ``start + audio_offset`` seconds into the performance (see
:mod:`dsl.plan`); the mix is exactly ``n_frames / FPS`` seconds long (rounded to a sample),
at the highest sample rate of its sources (others are resampled), mono, in [-1, 1].

Overlapping speech (an interruption: a negative ``@gap``) is the sum of both voices, each
whole: the interrupted speaker finishes its line under the interruption. Where voices that
sound together would add up past full scale, the whole mix is scaled down to fit instead of
clipping them (a performance without overlaps is never scaled: one voice at a time is
clipped to [-1, 1] as it always was).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.skeleton import FPS


def mix(parts, n_frames: int, sample_rate: int | None = None) -> tuple[np.ndarray, int]:
    """(samples float32, sample rate) of ``parts`` — (audio file, seconds from frame 0) pairs —
    over ``n_frames`` motion frames. Audio past the end is cut (it never is for a planned
    performance: every utterance's motion lasts past its speech)."""
    import soundfile as sf

    from model.features import load_audio  # lazy: the audio readers (soundfile for non-WAV files)

    parts = [(Path(p), float(at)) for p, at in parts if p is not None]
    if sample_rate is None:
        sample_rate = max((sf.info(str(p)).samplerate for p, _ in parts), default=22050)
    n = int(round(n_frames / FPS * sample_rate))
    out = np.zeros(n, np.float32)
    voices = np.zeros(n, np.uint8)  # how many utterances sound at each sample
    for path, at in parts:
        audio = load_audio(path, sample_rate)
        a = int(round(at * sample_rate))
        lo, hi = max(0, a), min(n, a + len(audio))
        if hi > lo:
            out[lo:hi] += audio[lo - a : hi - a]
            voices[lo:hi] += 1
    together = voices > 1
    if together.any() and float(np.abs(out[together]).max()) > 1.0:  # overlapping speech: no clipping
        out *= np.float32(1.0 / float(np.abs(out).max()))
    return np.clip(out, -1.0, 1.0), int(sample_rate)

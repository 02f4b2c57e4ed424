"""Reading and resampling speech without scipy.signal or soundfile: the same numbers."""

from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf
from scipy.signal import resample_poly as scipy_resample_poly

from dsl.speech.audio import read_wav, resample_poly, wav_bytes
from model.features import load_audio


@pytest.mark.parametrize("n, up, down", [(110250, 16000, 22050), (48000, 16000, 48000), (1000, 3, 2), (777, 16000, 44100),
                                         (1234, 7, 1), (5, 320, 441), (1, 320, 441), (0, 320, 441), (300, 2, 2)])
def test_resample_poly_equals_scipy(n, up, down):
    x = np.random.default_rng(n).normal(size=n)
    ours, theirs = resample_poly(x, up, down), scipy_resample_poly(x, up, down)
    assert ours.shape == theirs.shape
    assert np.abs(ours - theirs).max(initial=0.0) < 1e-12


@pytest.mark.parametrize("channels, rate", [(1, 22050), (2, 44100), (1, 16000)])
def test_wav_reading_and_load_audio_equal_soundfile_and_scipy(tmp_path, channels, rate):
    rng = np.random.default_rng(channels)
    samples = (rng.normal(size=(rate // 2, channels)) * 8000).astype(np.int16)
    path = tmp_path / "s.wav"
    sf.write(str(path), samples, rate, subtype="PCM_16")
    data, sr = read_wav(path)
    expected, expected_sr = sf.read(str(path), dtype="float32", always_2d=True)
    assert sr == expected_sr and np.array_equal(data, expected)
    mono = expected.mean(axis=1)
    if rate != 16000:
        g = np.gcd(rate, 16000)
        mono = scipy_resample_poly(mono, 16000 // g, rate // g).astype(np.float32)
    assert np.abs(load_audio(path) - mono).max() < 1e-6  # float32 rounding: scipy filters float32 in float32


def test_other_audio_files_go_to_soundfile(tmp_path):
    path = tmp_path / "s.flac"
    tone = np.sin(np.arange(8000) / 10.0).astype(np.float32) * 0.5
    sf.write(str(path), tone, 16000)
    assert read_wav(path) is None
    assert np.abs(load_audio(path) - tone).max() < 1e-4  # FLAC is 16-bit
    float_wav = tmp_path / "f.wav"
    sf.write(str(float_wav), tone, 16000, subtype="FLOAT")
    assert read_wav(float_wav) is None and np.array_equal(load_audio(float_wav), tone)
    (tmp_path / "mono.wav").write_bytes(wav_bytes(tone, 16000))
    assert np.abs(load_audio(tmp_path / "mono.wav") - tone).max() < 1e-4


@pytest.mark.parametrize("rate_in", [8000, 22050, 24000, 44100, 48000, 16000])
def test_resampling_in_pieces_gives_the_numbers_of_the_whole(rate_in):
    """A stream's audio chunks (any sizes, one sample included) resampled one by one are the
    whole audio resampled at once, and the resampler keeps only a bounded tail of the input."""
    from dsl.speech.audio import StreamResampler

    rng = np.random.default_rng(rate_in)
    x = rng.standard_normal(rate_in + 777)
    whole = resample_poly(x, 16000, rate_in)
    r = StreamResampler(rate_in, 16000)
    parts, at, kept = [], 0, []
    while at < len(x):
        n = int(rng.choice([1, 7, 300, 4000]))
        parts.append(r.push(x[at : at + n]))
        kept.append(len(r.buffer))
        at += n
    parts.append(r.flush())
    assert np.array_equal(np.concatenate(parts), whole)
    assert max(kept) < 5000 + 2 * (r.reach + r.down)

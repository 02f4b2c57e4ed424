"""Audio features: silence, the same bits with any BLAS thread count."""

import numpy as np

from model.features import audio_features


def test_a_recording_of_digital_silence_reads_as_the_floor_not_nan():
    from model.features import FLOOR_DB, speech_level

    level = speech_level(np.zeros((40, 5)))
    assert np.all(np.isfinite(level)) and level.shape == (1, 5)
    feats = audio_features(np.zeros(22050, np.float32), 15)
    assert np.all(np.isfinite(feats))
    assert np.allclose(feats, feats[0])  # every frame and band reads the same floor
    assert FLOOR_DB > 0


def test_features_are_the_same_bits_with_one_or_two_blas_threads():
    """Worker processes and their parent may run BLAS with different thread counts; a corpus
    shard built by `--jobs 2` differed from `--jobs 1` (CI) because the mel bands were a BLAS
    matrix product, whose sums change with the thread count."""
    from threadpoolctl import threadpool_limits

    from model.features import HOP

    rng = np.random.default_rng(0)
    n = 300 * HOP
    speechlike = rng.standard_normal(n) * np.sin(np.arange(n) / 3000.0) ** 2 * 0.1
    got = []
    for threads in (1, 2):
        with threadpool_limits(limits=threads):
            got.append(audio_features(speechlike.astype(np.float32), 320, 10))
    assert got[0].tobytes() == got[1].tobytes()


def test_nan_percentile_is_numpys_bits():
    import warnings

    from model.features import nan_percentile

    rng = np.random.default_rng(1)
    for trial in range(400):
        values = rng.random((int(rng.integers(1, 300)), int(rng.integers(1, 35)))) ** 4
        values[rng.random(values.shape) < rng.random()] = np.nan
        if trial % 7 == 0:
            values[:, 0] = np.nan  # a column of silence
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            expected = np.nanpercentile(values, 90.0, axis=0, keepdims=True)
        assert np.array_equal(nan_percentile(values, 90.0), expected, equal_nan=True)


def test_a_speech_files_features_are_computed_once_and_again_when_it_changes(tmp_path, monkeypatch):
    """The same speech file again (a service's speech cache gives the same line the same file)
    is not read, resampled and analysed again: the features come from the cache, the same
    numbers, a copy the engine may change. A changed file is read again."""
    import wave
    from types import SimpleNamespace

    import model.features as features

    monkeypatch.setattr(features, "FEATURE_CACHE", features.FeatureCache(1 << 20))
    reads = []
    real = features.load_audio
    monkeypatch.setattr(features, "load_audio", lambda path, *a: reads.append(path) or real(path, *a))

    def write(path, seconds, freq):
        t = np.arange(int(22050 * seconds)) / 22050
        with wave.open(str(path), "wb") as w:
            w.setnchannels(1)
            w.setsampwidth(2)
            w.setframerate(22050)
            w.writeframes((np.sin(2 * np.pi * freq * t) * np.sin(t * 3) * 12000).astype("<i2").tobytes())

    wav = tmp_path / "line.wav"
    write(wav, 2.0, 220)
    inputs = SimpleNamespace(audio_path=wav, lead_in=0.2, words=[])
    first, _, _ = features.speech_inputs(inputs, 40)
    fresh = features.audio_features(real(wav), 40, offset_frames=3)
    assert np.array_equal(first, fresh)
    first[:] = 0  # the engine's copy
    again, _, _ = features.speech_inputs(inputs, 40)
    assert len(reads) == 1 and np.array_equal(again, fresh)
    features.speech_inputs(SimpleNamespace(audio_path=wav, lead_in=0.0, words=[]), 40)  # another timeline
    assert len(reads) == 2
    write(wav, 2.5, 440)  # the file changed
    changed, _, _ = features.speech_inputs(inputs, 40)
    assert len(reads) == 3 and np.array_equal(changed, features.audio_features(real(wav), 40, offset_frames=3))
    assert not np.array_equal(changed, fresh)
    wav.unlink()  # gone: silence, as for a line without speech
    assert np.array_equal(features.speech_inputs(inputs, 40)[0], features.silence_features(40))


def test_the_feature_cache_keeps_to_its_budget():
    from model.features import FeatureCache

    cache = FeatureCache(3 * 400)
    for k in range(5):
        cache.put(k, np.full((10, 10), k, np.float32))  # 400 bytes each
    assert cache.used <= 3 * 400 and list(cache.items) == [2, 3, 4]
    assert cache.get(2) is not None  # used: the last to go now
    cache.put(5, np.zeros((10, 10), np.float32))
    assert list(cache.items) == [4, 2, 5]
    cache.put(6, np.zeros((40, 10), np.float32))  # larger than the whole budget: not kept
    assert 6 not in cache.items

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

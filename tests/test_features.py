"""Audio features: silence."""

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

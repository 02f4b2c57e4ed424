"""scripts/stream_style_check.py: both engines get the requested style, from a clip's words."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from core.words import TimedWord
from model.features import word_features
from model.style import style as style_of

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "stream_style_check.py"


@pytest.fixture(scope="module")
def check():
    spec = importlib.util.spec_from_file_location("stream_style_check", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_clip_words_are_in_order_and_never_overlap(check):
    clip = {"meta": {"words": [{"word": "world", "start": 0.6, "end": 1.0}, {"word": "hello", "start": 0.1, "end": 0.5},
                               {"word": "'s", "start": 0.3, "end": 0.4}, {"word": " ", "start": 1.1, "end": 1.2},
                               {"word": "again", "start": 1.0, "end": 1.4}]}}
    assert check.clip_words(clip) == [TimedWord("hello", 0.1, 0.5), TimedWord("world", 0.6, 1.0), TimedWord("again", 1.0, 1.4)]


@pytest.mark.parametrize("engine", ["offline", "stream"])
def test_a_faster_request_gives_faster_motion(check, engine):
    words = [TimedWord(w, 0.2 + 0.45 * i, 0.55 + 0.45 * i) for i, w in enumerate(
        "the shops on this floor open at nine every morning and close late".split())]
    run = getattr(check, engine)
    achieved = []
    for value in (-2.0, 2.0):
        motion = run(words, "speed", value, 0)
        ids, _ = word_features(words, len(motion))
        achieved.append(float(style_of(motion)[ids > 0, 0].mean()))
    assert achieved[1] - achieved[0] > 2.0, achieved
    assert np.isfinite(achieved).all()

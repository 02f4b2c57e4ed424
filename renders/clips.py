"""Choosing and joining utterances of a motion file (no GL, numpy only)."""

from __future__ import annotations

import numpy as np

from core.hands import concat
from core.motion import MotionClip
from core.skeleton import FPS
from core.words import shift_words


def concat_clips(clips: list[MotionClip]) -> MotionClip:
    """Utterances one after another: word times and control frames shifted to match."""
    if len(clips) == 1:
        return clips[0]
    if not clips:
        raise ValueError("no utterances")
    words, controls, texts = [], [], []
    offset = 0
    for c in clips:
        words += shift_words(c.words, offset / FPS)
        controls += [k.shifted(offset) for k in c.controls]
        offset += c.n_frames
    speakers = {c.speaker for c in clips}
    for c in clips:
        if c.text:
            texts.append(f"{c.speaker}: {c.text}" if c.speaker and len(speakers) > 1 else c.text)
    return MotionClip(
        poses=np.concatenate([c.poses for c in clips]),
        positions=np.concatenate([c.positions for c in clips]),
        hands=concat([c.hands for c in clips]),
        speaker=speakers.pop() if len(speakers) == 1 else None,
        text=" / ".join(texts) or None,
        words=words,
        controls=controls,
    )


def pick(clips: list[MotionClip], utterance: int | None) -> list[MotionClip]:
    """The clips to use: all of them, or utterance N (0-based). Raises IndexError."""
    if utterance is None:
        return list(clips)
    if not 0 <= utterance < len(clips):
        raise IndexError(f"no utterance {utterance}: the motion has {len(clips)} (0..{len(clips) - 1})")
    return [clips[utterance]]

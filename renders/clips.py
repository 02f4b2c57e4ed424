"""Choosing and joining utterances of a motion file, and a speaker's track as one clip on the
performance clock (no GL, numpy only)."""

from __future__ import annotations

import numpy as np

from core.face import FaceTrack
from core.face import concat as concat_faces
from core.hands import concat
from core.motion import MotionClip, Track
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
    faces = None  # a face where any clip has one (those without rest)
    if any(c.face is not None for c in clips):
        faces = concat_faces([c.face if c.face is not None else FaceTrack.neutral(c.n_frames) for c in clips])
    for c in clips:
        if c.text:
            texts.append(f"{c.speaker}: {c.text}" if c.speaker and len(speakers) > 1 else c.text)
    return MotionClip(
        poses=np.concatenate([c.poses for c in clips]),
        positions=np.concatenate([c.positions for c in clips]),
        hands=concat([c.hands for c in clips]),
        face=faces,
        speaker=speakers.pop() if len(speakers) == 1 else None,
        text=" / ".join(texts) or None,
        words=words,
        controls=controls,
    )


def speaker_name(speaker: str | None) -> str:
    """A speaker as a user reads it (and as files are named): its name, or ``unnamed``."""
    return speaker or "unnamed"


def track_clip(track: Track, clips: list[MotionClip]) -> MotionClip:
    """``track`` as one clip from the performance's frame 0, with its speaker's words and
    controls moved to the performance clock (what renders and exports of a track show)."""
    own = [c for c in clips if c.speaker == track.speaker]
    return MotionClip(
        poses=track.poses,
        positions=track.positions,
        hands=track.hands,
        face=track.face,
        speaker=track.speaker,
        text=" / ".join(c.text for c in own if c.text) or None,
        words=[w for c in own for w in shift_words(c.words, c.start)],
        controls=[k.shifted(c.start_frame) for c in own for k in c.controls],
    )


def utterance_frames(n_frames: int, clips: list[MotionClip], joined: bool = False) -> list[int | None]:
    """Per frame, the number of the utterance (0-based, the script's) playing then, None between
    them. ``joined``: the clips as :func:`concat_clips` puts them, one after another."""
    out: list[int | None] = [None] * n_frames
    at = 0
    for i, c in enumerate(clips):
        start = at if joined else c.start_frame
        out[start : start + c.n_frames] = [i if c.index is None else c.index] * len(out[start : start + c.n_frames])
        at += c.n_frames
    return out

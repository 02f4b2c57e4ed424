"""Small synthetic training clips for model tests: library gestures strung together.

Audio features carry the motion's speed (louder when the hands move), so a model can learn
something real from them in a few hundred steps.
"""

import numpy as np

from library import load_library
from model.features import AUDIO_DIM, WORD_BUCKETS
from core.skeleton import REST_POSE, mirror_pose


def synthetic_clips(n_clips: int = 12, frames: int = 150, seed: int = 0) -> list[dict]:
    rng = np.random.default_rng(seed)
    lib = load_library(use_config=False)
    names = lib.names()
    clips = []
    for _ in range(n_clips):
        pieces = []
        total = 0
        while total < frames:
            g = lib.get(names[rng.integers(len(names))])
            p = g.clip(speed=int(rng.integers(1, 3))).poses
            if rng.random() < 0.5:
                p = mirror_pose(p)
            rest = np.repeat(REST_POSE[None], int(rng.integers(2, 10)), axis=0)
            pieces += [p, rest]
            total += len(p) + len(rest)
        poses = np.concatenate(pieces)[:frames].astype(np.float32)
        speed = np.r_[0, np.linalg.norm(np.diff(poses, axis=0), axis=1)]
        audio = rng.normal(0, 0.3, (frames, AUDIO_DIM)).astype(np.float32)
        audio[:, 0] += speed * 10
        ids = rng.integers(1, WORD_BUCKETS, frames)
        onsets = (rng.random(frames) < 0.15).astype(np.float32)
        clips.append({"audio": audio, "word_ids": ids, "onsets": onsets, "poses": poses})
    return clips

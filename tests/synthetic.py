"""Small synthetic data for tests: training clips made of library gestures strung together,
and a fortunes file for tiny procedural corpora.

Audio features of the clips carry the motion's speed (louder when the hands move), so a model
can learn something real from them in a few hundred steps.
"""

import numpy as np

from core.skeleton import REST_POSE, mirror_pose
from library import load_library
from model.features import AUDIO_DIM, WORD_BUCKETS


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


#: A fortunes file (the corpus's text source) with a few speakable sentences and the things
#: the sentence cleaner must drop (attributions, ascii art, Q:/A:, too short).
FORTUNES = """\
Look over there, the big red house is where I grew up.
%
Never put off till tomorrow what you can do the day after tomorrow.
\t\t-- Mark Twain
%
    +--------+
    | ascii  |
    +--------+
%
Hello and welcome to the show. Maybe we will think of something small today!
%
Q: How many programmers does it take to change a light bulb?
A: None, that is a hardware problem.
%
Ok
%
"""


def write_fortunes(folder):
    """A fortunes folder holding :data:`FORTUNES` (and an index file the loader must skip)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "tiny").write_text(FORTUNES)
    (folder / "tiny.dat").write_bytes(b"\x00\x01binary")
    return folder

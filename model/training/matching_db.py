"""Build the matching engine's database (:mod:`model.matching`) from a corpus's training takes.

::

    python -m model.training.matching_db --corpus data/corpus -o model/weights/matching_db.npz

For every clip of the split (default ``train``, the clips the network trains on): its poses
(stored as int16, 1/32767 of a unit), its per-frame speech features (:func:`model.matching.frame_features`
of the augmented audio features the network mostly trains on, and the words), standardised,
and the PCA keys of every candidate segment's speech window; each frame's style (SGToolkit
Eq. 4-6) and each take's mean style over its speaking frames; the pose PCA of the entry cost.
Deterministic: the same corpus gives the same bytes.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import sys
import time
from pathlib import Path

import numpy as np

from core.fileio import atomic_write
from model import matching
from model.style import style as style_of
from model.training.corpus import load_corpus

#: Components of the speech window keys and of the entry pose.
KEY_COMPONENTS = 24
POSE_COMPONENTS = 12


def _pca(x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(mean, basis (D, k)) of the rows of ``x``; each component's sign fixed (largest entry positive)."""
    x = np.asarray(x, np.float64)
    mean = x.mean(0)
    # (one row has no covariance: np.cov would give NaN; any basis serves a single point)
    cov = np.cov((x - mean).T) if len(x) > 1 else np.zeros((x.shape[1], x.shape[1]))
    vals, vecs = np.linalg.eigh(cov)
    basis = vecs[:, np.argsort(vals)[::-1][:k]]
    basis *= np.sign(basis[np.abs(basis).argmax(0), np.arange(basis.shape[1])])
    return mean.astype(np.float32), basis.astype(np.float32)


def build(corpus, split: str = "train") -> tuple[dict, dict]:
    """The arrays and meta of a database of ``corpus``'s ``split``."""
    clips = load_corpus(corpus, split)
    if not clips:
        raise ValueError(f"no {split} clips in {corpus}")
    arrays, meta = build_from_clips(clips)
    meta.update(split=split, corpus=str(Path(corpus).name))
    return arrays, meta


def gives_segments(n_frames: int) -> bool:
    """Whether a take of ``n_frames`` frames holds a candidate segment (see :func:`min_frames`)."""
    return len(matching.candidate_starts(np.array([0, n_frames]))) > 0


def min_frames() -> int:
    """The fewest frames of a take that holds a candidate segment (a segment, its blend and the
    entry frames before it: :func:`model.matching.candidate_starts`)."""
    return next(n for n in range(1, 10 * matching.SEGMENT) if gives_segments(n))


def build_from_clips(clips, progress=None) -> tuple[dict, dict]:
    """The arrays and meta of a database of ``clips`` (dicts with ``poses`` (T, 27), ``audio``
    (T, AUDIO_DIM), ``word_ids`` and ``onsets`` (T,) and an ``id``, as :func:`load_corpus` gives
    them); each clip needs at least :func:`min_frames` frames to give a candidate.
    ``progress(done, total, what)`` after each clip's features."""
    if not clips:
        raise ValueError("no takes to build a database from")
    poses = [np.asarray(c["poses"], np.float32) for c in clips]
    lengths = np.array([len(p) for p in poses])
    clip_starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    audio = np.concatenate([c["audio"] for c in clips]).astype(np.float32)
    audio_mean, audio_basis = _pca(audio, matching.AUDIO_COMPONENTS)
    feats = []
    for n, c in enumerate(clips):
        if progress:
            progress(n, len(clips), str(c["id"]))
        feats.append(matching.frame_features(c["audio"], c["word_ids"], c["onsets"], audio_mean, audio_basis))
    if progress:
        progress(len(clips), len(clips), "")
    feats = np.concatenate(feats)
    feat_mean, feat_std = feats.mean(0), np.maximum(feats.std(0), 1e-6)
    feats = (feats - feat_mean) / feat_std * matching.FEATURE_WEIGHTS
    cands = matching.candidate_starts(clip_starts)
    if not len(cands):
        raise ValueError(f"no take is long enough for a segment ({min_frames()} frames)")
    # windows never reach into the neighbouring take: hold each take's edge frames
    keys = []
    for a, b in zip(clip_starts[:-1], clip_starts[1:]):
        inside = cands[(cands >= a) & (cands < b)]
        keys.append(matching.window_keys(feats[a:b], inside - a))
    keys = np.concatenate(keys)
    key_mean, key_basis = _pca(keys, KEY_COMPONENTS)
    speech_keys = (keys - key_mean) @ key_basis
    all_poses = np.concatenate(poses)
    pose_mean, pose_basis = _pca(all_poses, POSE_COMPONENTS)
    frame_style = np.concatenate([style_of(p) for p in poses]).astype(np.float32)
    take_style = np.array([style_of(p)[np.asarray(c["word_ids"]) > 0].mean(0) if (np.asarray(c["word_ids"]) > 0).any()
                           else style_of(p).mean(0) for c, p in zip(clips, poses)], np.float32)
    arrays = {
        "poses": np.round(np.clip(all_poses, -1, 1) * 32767).astype(np.int16),
        "clip_starts": clip_starts,
        "frame_style": frame_style.astype(np.float16),
        "take_style": take_style,
        "audio_mean": audio_mean, "audio_basis": audio_basis,
        "feat_mean": feat_mean.astype(np.float32), "feat_std": feat_std.astype(np.float32),
        "key_mean": key_mean, "key_basis": key_basis,
        "pose_mean": pose_mean, "pose_basis": pose_basis,
        "speech_keys": speech_keys.astype(np.float16),
    }
    meta = {"format": matching.FORMAT, "version": matching.VERSION, "segment": matching.SEGMENT,
            "stride": matching.STRIDE, "blend": matching.BLEND, "takes": len(clips),
            "frames": int(clip_starts[-1]), "candidates": int(len(cands))}
    meta["clip_ids_sha256"] = hashlib.sha256(" ".join(c["id"] for c in clips).encode()).hexdigest()
    return arrays, meta


def write(path, arrays: dict, meta: dict) -> str:
    """Write the database (compressed npz, fixed timestamps) atomically; its sha256."""
    buf = io.BytesIO()
    np.savez_compressed(buf, meta=np.array(json.dumps(meta, sort_keys=True)), **arrays)
    data = buf.getvalue()
    atomic_write(path, data)
    return hashlib.sha256(data).hexdigest()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description="build the matching engine's database from a corpus")
    p.add_argument("--corpus", default="data/corpus")
    p.add_argument("--split", default="train")
    p.add_argument("-o", "--output", default=str(matching.DEFAULT_DB))
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    arrays, meta = build(args.corpus, args.split)
    digest = write(args.output, arrays, meta)
    size = Path(args.output).stat().st_size
    print(f"wrote {args.output}: {meta['takes']} takes, {meta['frames']} frames, {meta['candidates']} candidates, "
          f"{size / 2**20:.1f} MiB, sha256 {digest}, {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

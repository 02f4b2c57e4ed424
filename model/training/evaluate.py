"""Evaluation on a held-out split of the corpus: the SGToolkit Table 1 conditions and more.

Every held-out clip is one evaluation window (the corpus clips are single utterances of
1.3-14 s). Conditions, all against the clip's reference motion:

- ``model``: the generator with no controls (fully automatic);
- ``model + pose``: a 5-frame pose control copied from the reference in the middle of the clip
  (SGToolkit Eq. 8, :func:`~model.training.metrics.pose_control`), raw network output
  (``no blend``) and with the exact blend;
- ``model + style``: style controls computed from the reference over the whole clip (Eq. 9,
  :func:`~model.training.metrics.style_control`);
- ``mean pose``: the static mean pose of the training split (PCS/SCS against the same
  controls, to show their range, as the paper's asterisked entries);
- ``rules``: the rule teacher with another random seed (same words, style, side and audio accents);
- ``keyframe``: the MANUAL baseline through the same 5-frame pose control.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.controls import ControlArrays
from core.skeleton import mirror_pose, normalize_pose
from core.words import TimedWord
from model import keyframe, neural, postprocess
from model.teacher import teach
from model.training import metrics
from model.training.corpus import load_corpus
from model.weights import load_weights

#: The ``rules`` condition's teacher seeds: ``RULES_SEED + seed + i`` for clip ``i`` (not the corpus's).
RULES_SEED = 10_000


def _neural(model, clip, arrays, seed, blend=True, smoothing="one_euro"):
    raw = neural.run_windows(model, clip["audio"], clip["word_ids"], clip["onsets"], arrays, seed)
    return postprocess.finish(raw, arrays.pose, arrays.pose_mask, smoothing=smoothing, blend=blend)


def _rules(clip, seed):
    """The teacher with another random seed on the clip's words, style, side and accents (the
    accent strength of its audio, stored by the corpus; word onsets for corpora without it)."""
    meta = clip["meta"]
    poses = teach([TimedWord.from_dict(w) for w in meta["words"]], len(clip["poses"]), style=meta.get("teacher_style") or meta.get("style"),
                  strength=clip.get("accent"), rng=np.random.default_rng(RULES_SEED + seed))
    return mirror_pose(poses) if meta.get("mirror") else poses


def mean_pose(clips) -> np.ndarray:
    """The static mean pose (27,) of ``clips`` (the training split), unit bones."""
    return normalize_pose(np.concatenate([c["poses"] for c in clips]).mean(axis=0))


def condition_motions(clips, model, mean: np.ndarray, *, seed: int = 0, smoothing: str = "one_euro",
                      progress=None) -> dict[str, tuple]:
    """Every condition's motions for ``clips``: name -> ``(references, generated[, controls])``,
    as :func:`model.training.metrics.report` takes them; clip ``i`` is generated with seed
    ``seed + i``. ``smoothing``: see :func:`evaluate_corpus`."""
    refs = [c["poses"] for c in clips]
    out = {k: [] for k in ("free", "pose_raw", "pose", "style", "mean", "rules", "keyframe")}
    pcs_ctl, sty_ctl = [], []
    for i, (clip, ref) in enumerate(zip(clips, refs)):
        if progress:
            progress(i, len(clips), "")
        pc, sc = metrics.pose_control(ref), metrics.style_control(ref)
        pcs_ctl.append(pc)
        sty_ctl.append(sc)
        empty = ControlArrays.empty(len(ref))
        out["free"].append(_neural(model, clip, empty, seed + i, smoothing=smoothing))
        out["pose_raw"].append(_neural(model, clip, pc, seed + i, blend=False, smoothing="none"))
        out["pose"].append(_neural(model, clip, pc, seed + i, smoothing=smoothing))
        out["style"].append(_neural(model, clip, sc, seed + i, smoothing=smoothing))
        out["mean"].append(np.repeat(mean[None], len(ref), axis=0))
        out["rules"].append(_rules(clip, seed + i))
        out["keyframe"].append(keyframe.generate(pc, mean_pose=mean))
    if progress:
        progress(len(clips), len(clips), "")
    both = [{**p.as_dict(), "style": s.style, "style_mask": s.style_mask} for p, s in zip(pcs_ctl, sty_ctl)]
    return {
        "model": (refs, out["free"]),
        "model+pose raw": (refs, out["pose_raw"], pcs_ctl),
        "model+pose": (refs, out["pose"], pcs_ctl),
        "model+style": (refs, out["style"], sty_ctl),
        "mean pose": (refs, out["mean"], both),
        "rules": (refs, out["rules"]),
        "keyframe": (refs, out["keyframe"], pcs_ctl),
    }


def evaluate_corpus(corpus: Path | str, *, split: str = "test", weights=None, extractor="default", seed: int = 0,
                    progress=None, limit: int | None = None, smoothing: str = "one_euro") -> list[dict]:
    """Table rows (see :func:`model.training.metrics.report`) for every condition on ``split``.

    ``smoothing`` is the neural engine's post-filter for the model rows (``model+pose raw`` is
    always unsmoothed and unblended: the network's own pose following)."""
    clips = load_corpus(corpus, split)
    if limit:
        clips = clips[:limit]
    model, _ = load_weights(weights)
    conditions = condition_motions(clips, model, mean_pose(load_corpus(corpus, "train")), seed=seed,
                                   smoothing=smoothing, progress=progress)
    return metrics.report(conditions, extractor=extractor)

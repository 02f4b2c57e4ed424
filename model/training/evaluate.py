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
- ``keyframe``: the MANUAL baseline through the same 5-frame pose control;
- ``shuffled audio``: the beat alignment of the ``model`` row's motions against the speech
  onsets of *another* clip (clip ``i + 1``'s clean audio, repeated or cut to clip ``i``'s
  length): the chance level of the beat alignment column (its other columns are not applicable);
- ``rules, shuffled``: the same for the ``rules`` row: the teacher's own margin over chance,
  the most a model that learns from it can be expected to show.

Every row's beat alignment (``beat_align``) is against the onsets of the clip's clean audio.
:func:`style_following` measures requested versus achieved style over the range.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.controls import STYLE_NAMES, ControlArrays
from core.skeleton import mirror_pose, normalize_pose
from core.words import TimedWord
from model import flow, keyframe, matching, neural, postprocess
from model.engines import DEFAULT_ENGINE
from model.runtime import TorchRunner
from model.style import style as style_of
from model.teacher import teach
from model.training import metrics
from model.training.corpus import load_corpus
from model.weights import DEFAULT_WEIGHTS, load_weights, takes_of

#: The ``rules`` condition's teacher seeds: ``RULES_SEED + seed + i`` for clip ``i`` (not the corpus's).
RULES_SEED = 10_000


def _neural(model, clip, arrays, seed, blend=True, smoothing="one_euro"):
    """The neural engine on one clip: the network, the posture of the take drawn with the
    clip's seed (when the runner ``model`` carries training takes), then post-processing."""
    raw = neural.network_motion(model, clip["audio"], clip["word_ids"], clip["onsets"], arrays, seed)
    return postprocess.finish(raw, arrays.pose, arrays.pose_mask, smoothing=smoothing, blend=blend,
                              style=arrays.style, style_mask=arrays.style_mask)


class MatchingModel:
    """The matching engine's database as :func:`condition_motions` runs it: each clip draws the
    take whose style its free frames follow with the clip's seed (none with ``takes=False``)."""

    def __init__(self, db: matching.Database, takes: bool = True) -> None:
        self.db = db
        self.takes = takes


class FlowModel:
    """The flow engine's network as :func:`condition_motions` runs it (:func:`model.flow.motion`,
    then the post-processing of :func:`_neural`): ``runner`` a runner of its weights."""

    def __init__(self, runner) -> None:
        self.runner = runner


def _generate(model, clip, arrays, seed, blend=True, smoothing="one_euro"):
    """One clip's motion by the engine ``model`` stands for: a :class:`MatchingModel`, a
    :class:`FlowModel` or a runner of the network (:func:`_neural`). ``smoothing=None``: the
    engine's default."""
    if isinstance(model, FlowModel):
        raw = flow.motion(model.runner, clip["audio"], clip["word_ids"], clip["onsets"], arrays, seed)
        return postprocess.finish(raw, arrays.pose, arrays.pose_mask, smoothing=smoothing or "one_euro", blend=blend,
                                  style=arrays.style, style_mask=arrays.style_mask)
    if isinstance(model, MatchingModel):
        take = matching.draw_take(model.db, seed) if model.takes else None
        raw = matching.match(model.db, clip["audio"], clip["word_ids"], clip["onsets"], arrays, seed, take)
        return matching.finish(raw, arrays, smoothing=smoothing or matching.Options.smoothing, blend=blend)
    return _neural(model, clip, arrays, seed, blend, smoothing or "one_euro")


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
        out["free"].append(_generate(model, clip, empty, seed + i, smoothing=smoothing))
        out["pose_raw"].append(_generate(model, clip, pc, seed + i, blend=False, smoothing="none"))
        out["pose"].append(_generate(model, clip, pc, seed + i, smoothing=smoothing))
        out["style"].append(_generate(model, clip, sc, seed + i, smoothing=smoothing))
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


def shuffled(features: list[np.ndarray]) -> list[np.ndarray]:
    """Clip ``i + 1``'s features (the last clip takes the first's), repeated or cut to clip
    ``i``'s length: audio that belongs to another utterance."""
    n = len(features)
    return [features[(i + 1) % n][np.arange(len(features[i])) % len(features[(i + 1) % n])] for i in range(n)]


def shuffled_row(motions, features, name: str = "shuffled audio") -> dict:
    """A shuffled-audio row: only ``beat_align`` (``motions`` against another clip's onsets)."""
    row = {k: float("nan") for k in metrics.ROW_KEYS}
    row.update(name=name, beat_align=metrics.clips_beat_alignment(motions, shuffled(features)),
               n_clips=len(motions), n_frames=int(sum(len(m) for m in motions)))
    return row


#: Requested style values of :func:`style_following`.
STYLE_LEVELS = (-2.0, -1.0, 1.0, 2.0)


def style_following(clips, model, *, seed: int = 0, smoothing: str = "one_euro", levels=STYLE_LEVELS) -> dict:
    """Requested versus achieved style: for each style dimension and each value of ``levels``,
    the model generates every clip with that one dimension requested on every frame (the others
    free); achieved = the mean over clips and frames of that dimension of the output's style
    (Eq. 4-6). Returns ``{name: {"requested", "achieved", "slope"}}``, ``slope`` the least-squares
    slope of achieved on requested (1 = follows the request over the whole range)."""
    out = {}
    for k, name in enumerate(STYLE_NAMES):
        achieved = []
        for value in levels:
            got = []
            for i, clip in enumerate(clips):
                arrays = ControlArrays.empty(len(clip["poses"]))
                arrays.style[:, k] = value
                arrays.style_mask[:, k] = 1.0
                speaking = np.asarray(clip["word_ids"]) > 0
                got.append(style_of(_generate(model, clip, arrays, seed + i, smoothing=smoothing))[speaking, k])
            achieved.append(float(np.concatenate(got).mean()))
        slope = float(np.polyfit(np.asarray(levels, np.float64), np.asarray(achieved), 1)[0])
        out[name] = {"requested": list(levels), "achieved": achieved, "slope": slope}
    return out


def format_style_following(result: dict) -> str:
    """The requested-versus-achieved table of :func:`style_following`."""
    levels = next(iter(result.values()))["requested"] if result else []
    head = "style       " + "".join(f" {v:+6.1f}" for v in levels) + "   slope"
    lines = [head, "-" * len(head)]
    for name, r in result.items():
        lines.append(f"{name:<12}" + "".join(f" {a:+6.2f}" for a in r["achieved"]) + f"  {r['slope']:6.2f}")
    lines.append("achieved style (normalised units, mean over the clips' speaking frames) for each requested value")
    return "\n".join(lines) + "\n"


def evaluate_corpus(corpus: Path | str, *, split: str = "test", weights=None, extractor="default", seed: int = 0,
                    progress=None, limit: int | None = None, smoothing: str = "one_euro",
                    with_style: bool = False, takes: bool = True, engine: str = DEFAULT_ENGINE,
                    database=None) -> list[dict] | tuple[list[dict], dict]:
    """Table rows (see :func:`model.training.metrics.report`) for every condition on ``split``
    ("all": every clip of the corpus, for a held-out corpus built with another seed),
    then the ``shuffled audio`` and ``rules, shuffled`` rows; with ``with_style`` also :func:`style_following`, as
    ``(rows, style)``.

    ``smoothing`` is the neural engine's post-filter for the model rows (``model+pose raw`` is
    always unsmoothed and unblended: the network's own pose following). ``takes``: draw
    each clip's take posture from the weights' training takes, as generation does
    (:mod:`model.take_posture`); false: the network alone. ``engine``: "neural" (``weights``),
    "flow" (``weights``: flow weights, default the shipped ``model/weights/flow.pt``; it draws no
    take posture) or "matching" (the database at ``database``, default the shipped one; ``takes``:
    each clip draws the take its free frames follow; ``smoothing`` None: the engine's default, none)."""
    clips = load_corpus(corpus, None if split == "all" else split)
    if limit:
        clips = clips[:limit]
    if engine == "matching":
        model = MatchingModel(matching.load(database), takes)
    elif engine == "flow":
        model = FlowModel(flow.load(weights))
    else:
        net, info = load_weights(weights)
        model = TorchRunner(net, takes_of(weights or DEFAULT_WEIGHTS, info) if takes else None)
    conditions = condition_motions(clips, model, mean_pose(load_corpus(corpus, "train")), seed=seed,
                                   smoothing=smoothing, progress=progress)
    audio = [c["audio_clean"] for c in clips]
    rows = metrics.report(conditions, extractor=extractor, audio=audio)
    rows.append(shuffled_row(conditions["model"][1], audio))
    rows.append(shuffled_row(conditions["rules"][1], audio, "rules, shuffled"))
    if not with_style:
        return rows
    return rows, style_following(clips, model, seed=seed, smoothing=smoothing)

"""Saving and loading generator weights, with refusal of incompatible files.

A weights file is a ``torch.save`` dict: ``format`` ("sgt-generator"), ``version``, the
``layout`` it was trained for (fps, pose and audio dimensions, word buckets, style names),
the network ``config``, its ``state_dict``, the normalisation ``style_stats`` and free-form
``meta`` (training command, data, metrics). A file for another layout or version is refused
with a message that says how to fix it, never misread.
"""

from __future__ import annotations

import io
from pathlib import Path

from core.controls import STYLE_NAMES
from core.fileio import atomic_write
from core.skeleton import FPS, JOINTS, POSE_DIM
from model.features import AUDIO_DIM, N_MELS, SAMPLE_RATE, WORD_BUCKETS
from model.style import load_stats

FORMAT = "sgt-generator"
VERSION = 1
DEFAULT_WEIGHTS = Path(__file__).with_name("weights") / "generator.pt"


class WeightsError(Exception):
    """A weights file that is missing, unreadable or made for another version."""


def layout() -> dict:
    return {
        "fps": FPS, "pose_dim": POSE_DIM, "joints": list(JOINTS), "audio_dim": AUDIO_DIM, "n_mels": N_MELS,
        "sample_rate": SAMPLE_RATE, "word_buckets": WORD_BUCKETS, "style_names": list(STYLE_NAMES),
    }


def save_weights(path: Path | str, model, meta: dict | None = None) -> None:
    import torch

    stats = load_stats()
    blob = {
        "format": FORMAT, "version": VERSION, "layout": layout(), "config": dict(model.config),
        "state_dict": {k: v.detach().cpu() for k, v in model.state_dict().items()},
        "style_stats": {"mean": list(stats.mean), "std": list(stats.std), "source": stats.source},
        "meta": meta or {},
    }
    buf = io.BytesIO()
    torch.save(blob, buf)
    atomic_write(path, buf.getvalue())


def load_weights(path: Path | str | None = None):
    """(GestureNet in eval mode, the file's dict without the state_dict)."""
    import torch

    from model.net import GestureNet  # lazy: torch

    path = Path(path) if path is not None else DEFAULT_WEIGHTS
    fix = "run 'sgt train' to make new weights, or restore the shipped file with 'git checkout model/weights/generator.pt'"
    if not path.exists():
        raise WeightsError(f"generator weights not found: {path}; {fix}")
    try:
        blob = torch.load(str(path), map_location="cpu", weights_only=True)
    except Exception as exc:  # truncated, not a torch file, ...
        raise WeightsError(f"cannot read generator weights {path}: {exc.__class__.__name__}; the file is corrupt. {fix}") from None
    if not isinstance(blob, dict) or blob.get("format") != FORMAT:
        raise WeightsError(f"{path} is not an sgt generator weights file; {fix}")
    if blob.get("version") != VERSION:
        raise WeightsError(f"{path} is weights format version {blob.get('version')}, this sgt reads version {VERSION}; {fix}")
    theirs, ours = blob.get("layout", {}), layout()
    diff = sorted(k for k in ours if theirs.get(k) != ours[k])
    if diff:
        raise WeightsError(f"{path} was trained for a different data layout ({', '.join(diff)} differ); {fix}")
    model = GestureNet({"smooth": 0, **(blob.get("config") or {})})  # files from before the option: off
    try:
        model.load_state_dict(blob["state_dict"])
    except (RuntimeError, KeyError) as exc:
        raise WeightsError(f"{path} does not match the network: {str(exc).splitlines()[0]}; {fix}") from None
    model.eval()
    info = {k: v for k, v in blob.items() if k != "state_dict"}
    return model, info

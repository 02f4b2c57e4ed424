"""Saving and loading generator weights, with refusal of incompatible files.

A weights file is a ``torch.save`` dict: ``format`` ("sgt-generator"), ``version``, the network's
``kind`` (:data:`KINDS`: absent for the regressor of the ``neural`` engine, "flow" for the flow
engine's sampler), the
``layout`` it was trained for (fps, pose and audio dimensions, word buckets, style names, the
control vector of :data:`core.controls.CONTROL_LAYOUT`), the network ``config``, its
``state_dict``, the style normalisation ``style_stats`` it was trained with, the postures of
its training takes ``takes`` (:mod:`model.take_posture`; files from before them have none)
and free-form ``meta`` (training command, data, metrics). A file for another layout or
version, of another kind than the engine asks for, or trained with other style statistics than
``model/style_stats.json`` (its style values would mean something else), is refused with a
message that says how to fix it, never misread.
"""

from __future__ import annotations

import hashlib
import io
import struct
import zipfile
from pathlib import Path

import numpy as np

from core.controls import CONTROL_LAYOUT, STYLE_NAMES
from core.fileio import atomic_write
from core.reading import InputFileError, read_bytes
from core.skeleton import FPS, JOINTS, POSE_DIM
from model.features import AUDIO_DIM, AUDIO_FEATURES, N_MELS, SAMPLE_RATE, WORD_BUCKETS
from model.style import STATS_PATH, load_stats
from model.take_posture import Takes, TakesError

FORMAT = "sgt-generator"
VERSION = 1
DEFAULT_WEIGHTS = Path(__file__).with_name("weights") / "generator.pt"
DEFAULT_FLOW_WEIGHTS = Path(__file__).with_name("weights") / "flow.pt"
FIX = "run 'sgt train' to make new weights, or restore the shipped file with 'git checkout model/weights/generator.pt'"
#: The networks a weights file may hold: kind -> (module, class, the engine that runs it, its
#: shipped file). A file records its kind (none: the regressor, as every file before the flow).
KINDS = {
    "neural": ("model.net", "GestureNet", "neural", DEFAULT_WEIGHTS),
    "flow": ("model.flow_net", "FlowNet", "flow", DEFAULT_FLOW_WEIGHTS),
}


def default_weights(kind: str = "neural") -> Path:
    """The shipped weights file of a network ``kind``."""
    return KINDS[kind][3]


def fix_for(kind: str = "neural") -> str:
    """How to get usable weights of a ``kind`` (the end of every refusal)."""
    if kind == "neural":
        return FIX
    return (f"run 'sgt train --engine {kind}' to make new weights, or restore the shipped file with "
            f"'git checkout model/weights/{default_weights(kind).name}'")


def kind_of(blob) -> str:
    """The network kind a weights file's dict (or an export's copy of it) records."""
    kind = blob.get("kind") if isinstance(blob, dict) else None
    return "neural" if kind is None else str(kind)


class WeightsError(Exception):
    """A weights file that is missing, unreadable or made for another version."""


def layout() -> dict:
    return {
        "fps": FPS, "pose_dim": POSE_DIM, "joints": list(JOINTS), "audio_dim": AUDIO_DIM, "n_mels": N_MELS,
        "sample_rate": SAMPLE_RATE, "word_buckets": WORD_BUCKETS, "style_names": list(STYLE_NAMES),
        "controls": [[name, width] for name, width in CONTROL_LAYOUT], "audio_features": AUDIO_FEATURES,
    }


#: Layout entries that files written before they were recorded were trained with.
_LAYOUT_BEFORE_RECORDED = {"controls": [["pose", 27], ["pose_mask", 1], ["style", 3], ["style_mask", 3]],
                           "audio_features": "log-mel+energy, per-utterance z-scores (v1)"}


def _stats_problem(path: Path, theirs: dict | None) -> str | None:
    """Why the file's style statistics differ from ``model/style_stats.json``, or None."""
    if not theirs:
        return None  # not recorded: nothing to compare
    ours = load_stats()
    if all(_same(theirs.get(k), getattr(ours, k)) for k in ("mean", "std")):
        return None
    return (f"{path} was trained with other style statistics than {STATS_PATH} (mean {_fmt(theirs.get('mean'))}, "
            f"std {_fmt(theirs.get('std'))} in the weights; mean {_fmt(ours.mean)}, std {_fmt(ours.std)} in the file), "
            f"so its style controls would mean something else. Put back the statistics it was trained with "
            f"('git checkout model/style_stats.json', or refit them from its data with scripts/fit_style_stats.py; "
            f"the weights say they come from: {theirs.get('source') or 'unknown'}), or train new weights with 'sgt train'")


def _same(values, reference) -> bool:
    try:
        a = np.asarray(values, np.float64)
    except (TypeError, ValueError):
        return False
    return a.shape == np.shape(reference) and bool(np.allclose(a, reference, rtol=1e-9, atol=0.0))


def _fmt(values) -> str:
    try:
        return "[" + ", ".join(f"{float(v):.4g}" for v in values) + "]"
    except (TypeError, ValueError):
        return repr(values)


def save_weights(path: Path | str, model, meta: dict | None = None) -> None:
    """Write ``model`` with its format, kind, layout, config and style statistics (atomically);
    its training takes are added afterwards by :func:`set_takes`."""
    import torch

    stats = load_stats()
    kind = getattr(model, "kind", "neural")
    blob = {
        "format": FORMAT, "version": VERSION, **({} if kind == "neural" else {"kind": kind}), "layout": layout(),
        "config": dict(model.config),
        "state_dict": {k: v.detach().cpu() for k, v in model.state_dict().items()},
        "style_stats": {"mean": list(stats.mean), "std": list(stats.std), "source": stats.source},
        "meta": meta or {},
    }
    buf = io.BytesIO()
    torch.save(blob, buf)
    atomic_write(path, buf.getvalue())


def check_info(path: Path, blob, kind: str | None = "neural") -> None:
    """Raise :class:`WeightsError` unless ``blob`` (a weights file's dict, or the copy an ONNX
    export records) is this sgt's format and version, holds the network ``kind`` (None: any of
    :data:`KINDS`), and matches the data layout and style statistics."""
    fix = fix_for(kind or "neural")
    if not isinstance(blob, dict) or blob.get("format") != FORMAT:
        raise WeightsError(f"{path} is not an sgt generator weights file; {fix}")
    theirs_kind = kind_of(blob)
    if theirs_kind not in KINDS:
        raise WeightsError(f"{path} holds a network of kind '{theirs_kind}' that this sgt does not know; {fix}")
    if kind is not None and theirs_kind != kind:
        raise WeightsError(f"{path} holds the {KINDS[theirs_kind][2]} engine's network, not the {KINDS[kind][2]} "
                           f"engine's: use it with --engine {KINDS[theirs_kind][2]}, or give --engine {KINDS[kind][2]} "
                           f"its own weights ({fix})")
    fix = fix_for(theirs_kind)
    if blob.get("version") != VERSION:
        raise WeightsError(f"{path} is weights format version {blob.get('version')}, this sgt reads version {VERSION}; {fix}")
    theirs, ours = blob.get("layout", {}), layout()
    diff = sorted(k for k in ours if theirs.get(k, _LAYOUT_BEFORE_RECORDED.get(k)) != ours[k])
    if diff:
        raise WeightsError(f"{path} was trained for a different data layout ({', '.join(diff)} differ); {fix}")
    problem = _stats_problem(path, blob.get("style_stats"))
    if problem:
        raise WeightsError(problem)
    takes_of(path, blob)


def takes_of(path: Path, blob) -> Takes | None:
    """The training takes a weights file (or an export's copy of its dict) carries; None for
    files from before they were recorded (and for the flow engine's, which samples its takes);
    :class:`WeightsError` for damaged ones."""
    if blob.get("takes") is None:
        return None
    try:
        return Takes.from_dict(blob["takes"])
    except TakesError as exc:
        raise WeightsError(f"{path} holds damaged training takes ({exc}); {fix_for(kind_of(blob))}") from None


def set_takes(path: Path | str, takes: Takes) -> None:
    """Record the training takes in an existing weights file (everything else kept; atomic)."""
    import torch

    path = Path(path)
    blob = _read(path)
    blob["takes"] = takes.as_dict()
    buf = io.BytesIO()
    torch.save(blob, buf)
    atomic_write(path, buf.getvalue())


def file_hash(path: Path | str) -> str:
    """SHA-256 of a weights file (what an ONNX export records to show which weights it holds)."""
    return hashlib.sha256(read_bytes(path, "weights")).hexdigest()


def load_weights(path: Path | str | None = None, kind: str | None = "neural"):
    """(the network in eval mode, the file's dict without the state_dict): a
    :class:`model.net.GestureNet` for the ``neural`` kind, a :class:`model.flow_net.FlowNet` for
    ``flow``; a file of another kind is refused (``kind`` None: whichever the file holds).
    ``path`` None: the kind's shipped file."""
    import importlib

    path = Path(path) if path is not None else default_weights(kind or "neural")
    blob = _read(path, kind)
    theirs = kind_of(blob)
    module, name = KINDS[theirs][:2]
    config = blob.get("config") or {}
    if theirs == "neural":
        config = {"smooth": 0, **config}  # files from before the option: off
    try:
        model = getattr(importlib.import_module(module), name)(config)  # lazy: torch
        model.load_state_dict(blob["state_dict"])
    except (RuntimeError, KeyError, ValueError, TypeError) as exc:
        raise WeightsError(f"{path} does not match the network: {str(exc).splitlines()[0]}; {fix_for(theirs)}") from None
    model.eval()
    info = {k: v for k, v in blob.items() if k != "state_dict"}
    return model, info


def _read(path: Path, kind: str | None = "neural") -> dict:
    """A weights file's dict, checked (:func:`check_info`); :class:`WeightsError` for a missing,
    unreadable or incompatible file."""
    import torch

    fix = fix_for(kind or "neural")
    if not path.exists():
        raise WeightsError(f"generator weights not found: {path}; {fix}")
    try:  # bounded, and a FIFO or a device refused unread
        data = read_bytes(path, "weights")
    except InputFileError as exc:
        raise WeightsError(f"cannot read generator weights {path}: {exc.reason}; {fix}") from None
    except OSError as exc:
        raise WeightsError(f"cannot read generator weights {path}: {exc.strerror or exc}; {fix}") from None
    why = not_torch_archive(data)  # stored entries only: torch.load's memory is bounded by the file's size
    if why:
        raise WeightsError(f"cannot read generator weights {path}: {why}; {fix}")
    try:
        blob = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - torch.load raises a dozen unrelated types on damaged files (UnpicklingError,
        # RuntimeError, EOFError, UnicodeDecodeError, IndexError, struct.error, KeyError, AssertionError...: measured on
        # truncated and mutated files); only torch.load is inside, and the error is reported with its type, not hidden
        raise WeightsError(f"cannot read generator weights {path}: {exc.__class__.__name__}; the file is corrupt. {fix}") from None
    check_info(path, blob, kind)
    return blob


def not_torch_archive(data: bytes) -> str | None:
    """Why ``data`` is not the archive ``torch.save`` writes (a zip whose entries are stored
    uncompressed, one of them ``data.pkl``), or None."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            entries = z.infolist()
    except (zipfile.BadZipFile, ValueError, struct.error):
        return "not a zip archive: it may be truncated" if data else "the file is empty"
    if not any(e.filename.endswith("/data.pkl") or e.filename == "data.pkl" for e in entries):
        return "no data.pkl in its archive"
    squeezed = next((e.filename for e in entries if e.compress_type != zipfile.ZIP_STORED or e.file_size != e.compress_size), None)
    return f"its entry {squeezed} is compressed; torch.save stores every entry as it is" if squeezed else None

"""Running the generator network: onnxruntime when a fresh ONNX export sits beside the weights,
else PyTorch.

``import torch`` alone costs 1.2-1.7 s, more than everything else a one-line ``sgt generate``
does; onnxruntime loads in about 0.15 s and runs the same network (outputs equal within 1e-5,
tests/test_runtime.py compares them). So the shipped weights ``model/weights/generator.pt``
ship with their export ``model/weights/generator.onnx``, made by ``python
scripts/export_onnx.py`` (:func:`export_onnx`). The export records the SHA-256 of the weights
file it was made from and the weights' format, layout and style statistics: :func:`load_runner`
uses it only when that hash matches the weights file next to it, and checks the recorded
layout exactly as :func:`model.weights.load_weights` checks a ``.pt`` file. A stale or missing
export (new weights not yet exported) falls back to PyTorch, so results never come from other
weights; tests/test_runtime.py fails while the shipped export is stale.

Both runners take one window, unbatched numpy arrays, and return (T, 27) float32 poses. The
flow engine's network (:mod:`model.flow_net`) runs through the same runners: its noise ``z``
is (T, 27), one noise vector per frame, where the regressor's is one (noise_dim,) per window
(``noise_dim`` of both is per frame or per window accordingly), and its export holds its whole
sampler, so one call is one window either way.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

from core.controls import STYLE_NAMES
from core.fileio import atomic_write
from core.interrupts import import_optional
from core.skeleton import POSE_DIM
from model.features import AUDIO_DIM
from model.weights import WeightsError, check_info, default_weights, file_hash, kind_of, load_weights, takes_of

#: The network's inputs, in the order of :meth:`model.net.GestureNet.forward`.
INPUTS = ("audio", "word_ids", "onsets", "pose", "pose_mask", "style", "style_mask", "z")
#: Keys of the weights file recorded in the export (what :func:`model.weights.check_info` reads).
_INFO_KEYS = ("format", "version", "kind", "layout", "config", "style_stats", "takes")
#: Threads of one onnxruntime session: the network is small (about 1 ms a window), so more
#: threads only add hand-over cost, and the service runs several sessions' calls side by side.
ORT_THREADS = 1


def onnx_path(weights: Path | str) -> Path:
    """Where the ONNX export of a weights file lives: beside it, ``.onnx`` for ``.pt``."""
    return Path(weights).with_suffix(".onnx")


class TorchRunner:
    """The network in PyTorch (any weights file; training and evaluation use it)."""

    kind = "torch"

    def __init__(self, net, takes=None) -> None:
        self.net = net
        self.noise_dim = int(net.config["noise_dim"])
        #: the training takes (:class:`model.take_posture.Takes`), None for weights without them
        self.takes = takes

    def run_window(self, audio, ids, onsets, pose, pose_mask, style, style_mask, z) -> np.ndarray:
        import torch

        def tens(a, dtype=torch.float32):
            return torch.as_tensor(np.ascontiguousarray(a), dtype=dtype)[None]

        with torch.inference_mode():
            y = self.net(tens(audio), tens(ids, torch.long), tens(onsets), tens(pose), tens(pose_mask), tens(style),
                         tens(style_mask), tens(z))
        return y[0].numpy()


class OnnxRunner:
    """The network in onnxruntime, from an export made by :func:`export_onnx`."""

    kind = "onnx"

    def __init__(self, session, info: dict) -> None:
        self.session = session
        self.info = info
        self.noise_dim = int(info["config"]["noise_dim"])
        self.takes = None  # the training takes; load_runner reads them from ``info``

    def run_window(self, audio, ids, onsets, pose, pose_mask, style, style_mask, z) -> np.ndarray:
        f32 = np.float32
        feeds = {
            "audio": audio.astype(f32)[None], "word_ids": ids.astype(np.int64)[None], "onsets": onsets.astype(f32)[None],
            "pose": pose.astype(f32)[None], "pose_mask": pose_mask.astype(f32)[None], "style": style.astype(f32)[None],
            "style_mask": style_mask.astype(f32)[None], "z": z.astype(f32)[None],
        }
        return self.session.run(None, feeds)[0][0]


def as_runner(model):
    """A runner for ``model``: a runner as it is, a :class:`model.net.GestureNet` wrapped."""
    return model if hasattr(model, "run_window") else TorchRunner(model)


def read_export(path: Path | str):
    """(onnxruntime session, the export's metadata dict) of an ONNX export; raises
    ``ImportError`` without onnxruntime, ``WeightsError`` for a file that is not an export."""
    ort = import_optional("onnxruntime")

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = ORT_THREADS
    opts.inter_op_num_threads = 1
    opts.log_severity_level = 3
    try:
        session = ort.InferenceSession(str(path), sess_options=opts, providers=["CPUExecutionProvider"])
        meta = session.get_modelmeta().custom_metadata_map
        return session, {"weights_sha256": meta["weights_sha256"], "weights_info": json.loads(meta["weights_info"])}
    except Exception as exc:  # noqa: BLE001 - onnxruntime raises its own untyped errors (Fail, InvalidProtobuf, ...)
        # for damaged files; the export is a cache of the weights, so it is reported, never trusted
        raise WeightsError(f"{path} is not a readable sgt ONNX export ({exc.__class__.__name__}); "
                           f"re-export it with 'python scripts/export_onnx.py'") from None


def fresh_export(weights: Path | str):
    """An :class:`OnnxRunner` for ``weights`` when its export exists, is readable, and was made
    from exactly this file; else None (the reason is not an error: PyTorch runs instead)."""
    path = onnx_path(weights)
    if not path.exists():
        return None
    try:
        session, meta = read_export(path)
    except (ImportError, WeightsError):
        return None
    if meta["weights_sha256"] != file_hash(weights):
        return None
    return OnnxRunner(session, meta["weights_info"])


@lru_cache(maxsize=4)
def load_runner(weights: str | None = None, kind: str = "neural"):
    """The fastest runner for a weights file of the network ``kind`` (None: the kind's shipped
    file). Raises :class:`~model.weights.WeightsError` for a missing or unusable file, or one of
    another kind, as :func:`~model.weights.load_weights` does."""
    path = Path(weights) if weights is not None else default_weights(kind)
    if path.exists():
        runner = fresh_export(path)
        if runner is not None:
            check_info(path, runner.info, kind)
            runner.takes = takes_of(path, runner.info)
            return runner
    net, info = load_weights(path, kind)
    return TorchRunner(net, takes_of(path, info))


def export_onnx(weights: Path | str | None = None, out: Path | str | None = None) -> Path:
    """Export a weights file's network (either kind: the flow engine's with its whole sampler)
    to ONNX (default: beside it), recording the weights' SHA-256 and their format, kind,
    layout, config, style statistics and training takes. Needs torch and onnx."""
    import io
    import warnings

    import onnx
    import torch

    weights = Path(weights) if weights is not None else default_weights()
    out = Path(out) if out is not None else onnx_path(weights)
    net, info = load_weights(weights, kind=None)
    per_frame = kind_of(info) != "neural"  # the flow's noise: one vector per frame
    t = 8  # any length: the time axis is dynamic
    n_style = len(STYLE_NAMES)
    noise = torch.zeros(1, t, net.config["noise_dim"]) if per_frame else torch.zeros(1, net.config["noise_dim"])
    example = (torch.zeros(1, t, AUDIO_DIM), torch.zeros(1, t, dtype=torch.long), torch.zeros(1, t), torch.zeros(1, t, POSE_DIM),
               torch.zeros(1, t), torch.zeros(1, t, n_style), torch.zeros(1, t, n_style), noise)
    axes = {name: {1: "frames"} for name in INPUTS if per_frame or name != "z"} | {"poses": {1: "frames"}}
    buf = io.BytesIO()
    with warnings.catch_warnings():  # the TorchScript exporter's notes on constant folding and GRU shapes
        warnings.simplefilter("ignore")
        torch.onnx.export(net, example, buf, input_names=list(INPUTS), output_names=["poses"], dynamic_axes=axes,
                          opset_version=17, dynamo=False)
    proto = onnx.load_from_string(buf.getvalue())
    recorded = {"weights_sha256": file_hash(weights), "weights_info": json.dumps({k: info[k] for k in _INFO_KEYS if k in info}),
                "source": f"exported from {weights.name} by scripts/export_onnx.py"}
    for key, value in recorded.items():
        entry = proto.metadata_props.add()
        entry.key, entry.value = key, value
    atomic_write(out, proto.SerializeToString())
    return out



def random_window(n_frames: int, noise_dim: int, rng, per_frame: bool = False) -> tuple:
    """Random network inputs for one window (unbatched), controls on about a third of the
    frames; the noise (noise_dim,), or (n_frames, noise_dim) with ``per_frame`` (the flow's)."""
    mask = (rng.random(n_frames) < 0.3).astype(np.float32)
    n_style = len(STYLE_NAMES)
    return (rng.normal(size=(n_frames, AUDIO_DIM)).astype(np.float32), rng.integers(0, 4096, n_frames),
            (rng.random(n_frames) < 0.2).astype(np.float32), rng.normal(size=(n_frames, POSE_DIM)).astype(np.float32), mask,
            rng.normal(size=(n_frames, n_style)).astype(np.float32), (rng.random((n_frames, n_style)) < 0.5).astype(np.float32),
            rng.standard_normal((n_frames, noise_dim) if per_frame else noise_dim).astype(np.float32))


def largest_difference(weights: Path | str, export: Path | str, lengths=(1, 2, 7, 37, 60), seed: int = 0) -> float:
    """Largest absolute difference between PyTorch and onnxruntime outputs on random windows
    (weights of either kind)."""
    net, info = load_weights(weights, kind=None)
    torch_runner = TorchRunner(net)
    session, meta = read_export(export)
    onnx_runner = OnnxRunner(session, meta["weights_info"])
    rng = np.random.default_rng(seed)
    worst = 0.0
    for n in lengths:
        inputs = random_window(n, torch_runner.noise_dim, rng, per_frame=kind_of(info) != "neural")
        worst = max(worst, float(np.abs(torch_runner.run_window(*inputs) - onnx_runner.run_window(*inputs)).max()))
    return worst

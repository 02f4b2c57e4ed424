"""The feature extractor of the Fréchet gesture distance (FGD), after Yoon et al. 2020.

A small 1-D convolutional autoencoder is trained to reconstruct windows of motion
(:data:`WINDOW` = 30 frames x 27 pose numbers, the window SGToolkit evaluates); the FGD
features of a window are the encoder's latent vector (:data:`LATENT` = 32 numbers).
:func:`model.training.metrics.fgd` fits a Gaussian to each feature set and measures the Fréchet
distance between them.

- :func:`train_extractor` trains one on a list of motions (deterministic for a seed);
- :meth:`FGDExtractor.features` turns motions into features over sliding windows
  (:data:`STRIDE` = 10 frames; a motion shorter than a window is padded by holding its last
  pose);
- :meth:`FGDExtractor.save` / :func:`load` write / read a small weights file (format
  ``sgt-fgd-extractor``, :data:`VERSION`); a missing, corrupt or incompatible file raises
  :class:`ExtractorError` with a message that says how to fix it;
- :func:`train_default_extractor` trains the shipped extractor
  (``model/weights/fgd_extractor.pt``) on the procedural corpus.

torch is imported inside functions only, so importing this module is cheap.
"""

from __future__ import annotations

import io
import math
import time
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from core.fileio import atomic_write
from core.reading import InputFileError, read_bytes
from core.skeleton import FPS, JOINTS, POSE_DIM
from model.training.corpus import load_corpus

FORMAT = "sgt-fgd-extractor"
VERSION = 1
WINDOW = 30
STRIDE = 10
LATENT = 32
CHANNELS = 48
DEFAULT_PATH = Path(__file__).resolve().parent.parent / "weights" / "fgd_extractor.pt"
DEFAULT_CORPUS = Path(__file__).resolve().parent.parent.parent / "data" / "corpus"


class ExtractorError(Exception):
    """A feature extractor file that is missing, unreadable or made for another layout."""


def layout() -> dict:
    """What an extractor file must agree with to be read."""
    return {"fps": FPS, "pose_dim": POSE_DIM, "joints": list(JOINTS), "window": WINDOW}


# --------------------------------------------------------------------------- windows

def windows(motions, window: int = WINDOW, stride: int = STRIDE) -> np.ndarray:
    """Sliding windows (N, window, 27) float32 of every motion (T_i, 27).

    Windows start at 0, stride, 2*stride, ... while they fit; when the last window does not end
    on the motion's last frame, one more window ending there is added (so every frame is seen).
    A motion shorter than ``window`` is padded by repeating its last pose.
    """
    if isinstance(motions, np.ndarray) and motions.ndim == 2:
        motions = [motions]
    out = []
    for m in motions:
        m = np.asarray(m, np.float32)
        if m.ndim != 2 or m.shape[1] != POSE_DIM or len(m) == 0:
            raise ValueError(f"expected motions of shape (T, {POSE_DIM}) with T >= 1, got {m.shape}")
        if len(m) < window:
            m = np.concatenate([m, np.repeat(m[-1:], window - len(m), axis=0)])
        starts = list(range(0, len(m) - window + 1, stride))
        if starts[-1] != len(m) - window:
            starts.append(len(m) - window)
        out.extend(m[s:s + window] for s in starts)
    if not out:
        return np.zeros((0, window, POSE_DIM), np.float32)
    return np.stack(out)


# --------------------------------------------------------------------------- network

def _build(config: dict):
    """The autoencoder as (encoder, decoder) torch modules for ``config``."""
    from torch import nn

    c, latent, w = config["channels"], config["latent"], config["window"]
    reduced = math.ceil(math.ceil(w / 2) / 2)  # two stride-2 convolutions

    encoder = nn.Sequential(
        nn.Conv1d(POSE_DIM, c, 3, padding=1), nn.LeakyReLU(0.2),
        nn.Conv1d(c, c, 4, stride=2, padding=1 if w % 2 == 0 else 2), nn.LeakyReLU(0.2),
        nn.Conv1d(c, c, 3, stride=2, padding=1), nn.LeakyReLU(0.2),
        nn.Flatten(), nn.Linear(c * reduced, latent),
    )

    class Decoder(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.fc = nn.Linear(latent, c * reduced)
            self.body = nn.Sequential(
                nn.LeakyReLU(0.2),
                nn.Upsample(scale_factor=2, mode="linear", align_corners=False),
                nn.Conv1d(c, c, 3, padding=1), nn.LeakyReLU(0.2),
                nn.Upsample(scale_factor=2, mode="linear", align_corners=False),
                nn.Conv1d(c, c, 3, padding=1), nn.LeakyReLU(0.2),
                nn.Conv1d(c, POSE_DIM, 3, padding=1),
            )

        def forward(self, z):
            x = self.fc(z).reshape(len(z), c, reduced)
            return self.body(x)[..., :w]

    return encoder, Decoder()


DEFAULT_CONFIG = {"channels": CHANNELS, "latent": LATENT, "window": WINDOW, "stride": STRIDE}


class FGDExtractor:
    """A trained encoder with its input normalisation; :meth:`features` gives FGD features."""

    def __init__(self, config: dict, mean: np.ndarray, std: np.ndarray, state: dict | None = None,
                 meta: dict | None = None) -> None:
        import torch

        self.config = {**DEFAULT_CONFIG, **config}
        self.mean = np.asarray(mean, np.float32).reshape(POSE_DIM)
        self.std = np.asarray(std, np.float32).reshape(POSE_DIM)
        self.encoder, self.decoder = _build(self.config)
        if state is not None:
            self.encoder.load_state_dict(state["encoder"])
            self.decoder.load_state_dict(state["decoder"])
        self.encoder.eval()
        self.decoder.eval()
        self.meta = dict(meta or {})
        self._torch = torch

    @property
    def window(self) -> int:
        return int(self.config["window"])

    @property
    def dim(self) -> int:
        return int(self.config["latent"])

    def _normalise(self, w: np.ndarray):
        x = (w - self.mean) / self.std  # (N, T, 27)
        return self._torch.from_numpy(np.ascontiguousarray(x.transpose(0, 2, 1), np.float32))

    def encode_windows(self, w: np.ndarray) -> np.ndarray:
        """Windows (N, window, 27) -> features (N, latent) float64."""
        torch = self._torch
        w = np.asarray(w, np.float32)
        if w.ndim != 3 or w.shape[1:] != (self.window, POSE_DIM):
            raise ValueError(f"expected windows (N, {self.window}, {POSE_DIM}), got {w.shape}")
        out = []
        with torch.no_grad():
            for i in range(0, len(w), 1024):
                out.append(self.encoder(self._normalise(w[i:i + 1024])).double().numpy())
        return np.concatenate(out) if out else np.zeros((0, self.dim))

    def features(self, motions, stride: int | None = None) -> np.ndarray:
        """Motions (a list of (T_i, 27), or one) -> features (N_windows, latent) float64."""
        return self.encode_windows(windows(motions, self.window, stride or int(self.config["stride"])))

    def reconstruct(self, w: np.ndarray) -> np.ndarray:
        """Windows (N, window, 27) -> the autoencoder's reconstruction, same shape."""
        torch = self._torch
        with torch.no_grad():
            y = self.decoder(self.encoder(self._normalise(np.asarray(w, np.float32)))).numpy()
        return y.transpose(0, 2, 1) * self.std + self.mean

    def reconstruction_error(self, motions) -> float:
        """Mean absolute error (pose units, as PCS) of reconstructing the windows of ``motions``."""
        w = windows(motions, self.window, int(self.config["stride"]))
        return float(np.abs(self.reconstruct(w) - w).mean())

    def save(self, path: Path | str) -> None:
        torch = self._torch
        blob = {
            "format": FORMAT, "version": VERSION, "layout": layout(), "config": dict(self.config),
            "mean": self.mean.tolist(), "std": self.std.tolist(),
            "state": {
                "encoder": {k: v.detach().cpu().clone() for k, v in self.encoder.state_dict().items()},
                "decoder": {k: v.detach().cpu().clone() for k, v in self.decoder.state_dict().items()},
            },
            "meta": self.meta,
        }
        buf = io.BytesIO()
        torch.save(blob, buf)
        atomic_write(path, buf.getvalue())


def load(path: Path | str | None = None) -> FGDExtractor:
    """Read an extractor file (default: the shipped ``model/weights/fgd_extractor.pt``)."""
    import torch

    path = Path(path) if path is not None else DEFAULT_PATH
    fix = ("train one with 'python -c \"from model.training.fgd import train_default_extractor; "
           "train_default_extractor()\"', or restore the shipped file with "
           "'git checkout model/weights/fgd_extractor.pt'")
    if not path.exists():
        raise ExtractorError(f"FGD feature extractor not found: {path}; {fix}")
    try:
        data = read_bytes(path, "weights")  # a FIFO or a device is refused unread (torch.load would block on it)
    except InputFileError as exc:
        raise ExtractorError(f"{path}: {exc.reason}; {fix}") from None
    except OSError as exc:
        raise ExtractorError(f"cannot read FGD feature extractor {path}: {exc.strerror or exc}; {fix}") from None
    try:
        blob = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - torch.load on a damaged file: see model.weights.load_weights
        raise ExtractorError(f"cannot read FGD feature extractor {path} ({exc.__class__.__name__}): the file is corrupt; {fix}") from None
    if not isinstance(blob, dict) or blob.get("format") != FORMAT:
        raise ExtractorError(f"{path} is not an sgt FGD feature extractor file; {fix}")
    if blob.get("version") != VERSION:
        raise ExtractorError(f"{path} is FGD extractor format version {blob.get('version')}, this sgt reads version {VERSION}; {fix}")
    theirs, ours = blob.get("layout") or {}, layout()
    diff = sorted(k for k in ours if theirs.get(k) != ours[k])
    if diff:
        raise ExtractorError(f"{path} was trained for a different data layout ({', '.join(diff)} differ); {fix}")
    try:
        return FGDExtractor(blob["config"], np.asarray(blob["mean"]), np.asarray(blob["std"]), blob["state"], blob.get("meta"))
    except (RuntimeError, KeyError, ValueError, TypeError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
        raise ExtractorError(f"{path} does not match the extractor network: {first}; {fix}") from None


# --------------------------------------------------------------------------- training

def train_extractor(
    motions: Sequence[np.ndarray],
    *,
    epochs: int = 40,
    seed: int = 0,
    progress: Callable[[int, float], None] | None = None,
    batch_size: int = 128,
    lr: float = 1e-3,
    channels: int = CHANNELS,
    latent: int = LATENT,
    stride: int = STRIDE,
    val_fraction: float = 0.1,
    max_seconds: float | None = None,
) -> FGDExtractor:
    """Train the autoencoder on the windows of ``motions`` (list of (T_i, 27)); deterministic.

    Inputs are normalised per pose number with the training windows' mean and std (stored in
    the extractor). Loss: mean squared reconstruction error of the normalised windows (Adam).
    ``progress(epoch, train_loss)`` is called after each epoch. ``val_fraction`` of the windows
    (chosen by the seed) are held out; ``extractor.meta`` records the final train loss and the
    held-out reconstruction error (mean absolute error in pose units). ``max_seconds`` stops
    early (recorded in meta) for time-boxed runs.
    """
    import torch

    w = windows(list(motions) if not isinstance(motions, np.ndarray) else motions, WINDOW, stride)
    if len(w) < 2:
        raise ValueError(f"need at least 2 training windows, got {len(w)}")
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(w))
    n_val = int(len(w) * val_fraction) if len(w) >= 20 else 0
    val, train = w[order[:n_val]], w[order[n_val:]]
    mean = train.reshape(-1, POSE_DIM).mean(0)
    std = np.maximum(train.reshape(-1, POSE_DIM).std(0), 1e-2)

    torch.manual_seed(seed)
    ext = FGDExtractor({"channels": channels, "latent": latent, "window": WINDOW, "stride": stride}, mean, std)
    params = list(ext.encoder.parameters()) + list(ext.decoder.parameters())
    opt = torch.optim.Adam(params, lr=lr)
    x_all = ext._normalise(train)
    gen = torch.Generator().manual_seed(seed)
    ext.encoder.train()
    ext.decoder.train()
    t0 = time.monotonic()
    loss_value = float("nan")
    done = 0
    for epoch in range(epochs):
        perm = torch.randperm(len(x_all), generator=gen)
        total, count = 0.0, 0
        for i in range(0, len(perm), batch_size):
            xb = x_all[perm[i:i + batch_size]]
            loss = torch.mean((ext.decoder(ext.encoder(xb)) - xb) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(xb)
            count += len(xb)
        loss_value = total / count
        done = epoch + 1
        if progress is not None:
            progress(done, loss_value)
        if max_seconds is not None and time.monotonic() - t0 > max_seconds:
            break
    ext.encoder.eval()
    ext.decoder.eval()
    ext.meta.update({
        "epochs": done, "seed": seed, "windows": int(len(train)), "val_windows": int(len(val)),
        "train_loss": loss_value, "train_seconds": round(time.monotonic() - t0, 1),
        "train_mae": float(np.abs(ext.reconstruct(train) - train).mean()),
        "val_mae": float(np.abs(ext.reconstruct(val) - val).mean()) if len(val) else float("nan"),
    })
    return ext


def train_default_extractor(corpus_path: Path | str = DEFAULT_CORPUS, out_path: Path | str = DEFAULT_PATH,
                            *, epochs: int = 40, seed: int = 0, progress=None, max_seconds: float | None = None) -> FGDExtractor:
    """Train the shipped extractor on the procedural corpus (:func:`model.training.corpus.load_corpus`).

    Trains on the corpus's ``train`` split, measures the reconstruction error (mean absolute
    error, pose units) on its ``val`` split when there is one, writes ``out_path`` and returns
    the extractor; ``meta`` holds the corpus path, the training figures and the errors.
    """
    motions = [c["poses"] for c in load_corpus(corpus_path, "train")]
    if not motions:
        raise ValueError(f"corpus {corpus_path} holds no training motions")
    ext = train_extractor(motions, epochs=epochs, seed=seed, progress=progress, max_seconds=max_seconds)
    val = [c["poses"] for c in load_corpus(corpus_path, "val")]
    ext.meta.update({
        "corpus": str(corpus_path), "n_motions": len(motions), "n_val_motions": len(val),
        "corpus_val_mae": ext.reconstruction_error(val) if val else float("nan"),
    })
    ext.save(out_path)
    return ext

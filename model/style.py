"""Style statistics (SGToolkit Eq. 4-6): speed, space and handedness of a motion.

For every frame i, over a window of ``WINDOW`` frames centred on i (stride 1; the window is
cut at the ends of the motion):

- speed: the summed per-frame displacement of all joints, averaged over the window (Eq. 4);
- space: the mean distance between the wrists (Eq. 5);
- handedness: relative wrist speeds (Eq. 6): ``speedL/speedR - 1`` when the right wrist is
  faster (negative: right-handed), else ``1 - speedR/speedL`` (positive: left-handed).

Raw values are normalised with the mean and standard deviation of a reference corpus and
clamped to [-3, 3] (the style control range). The same functions run on numpy arrays and on
torch tensors (differentiably), so the compiler, the generator's style loss and the metrics
share one implementation.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.controls import STYLE_LIMIT, STYLE_NAMES
from core.skeleton import BONE_LENGTH_ARRAY, BONES, JOINT_INDEX, JOINTS, N_BONES, ROOT_POSITION, positions_from_pose

#: Window of the style statistics, in frames (2 s at 15 fps), as in the paper.
WINDOW = 30
#: Where the normalisation statistics ship.
STATS_PATH = Path(__file__).with_name("style_stats.json")
_EPS = 1e-6
_LW = JOINT_INDEX["left_wrist"]
_RW = JOINT_INDEX["right_wrist"]


def _is_torch(x) -> bool:
    return type(x).__module__.startswith("torch")


def _norm(x):
    """Euclidean norm over the last axis, smooth at zero (for gradients)."""
    return ((x * x).sum(-1) + _EPS * _EPS) ** 0.5


def window_mean(x, window: int):
    """Centred moving mean over the last axis (time) of a numpy array or torch tensor: frame i
    averages frames [i - window // 2, i + window // 2], the window cut at the ends.

    The one centred window mean of sgt: the style statistics (Eq. 4-6) and
    :func:`model.postprocess.moving_average` use it."""
    half = window // 2
    if _is_torch(x):
        import torch

        c = torch.nn.functional.pad(torch.cumsum(x, dim=-1), (1, 0))
        t = x.shape[-1]
        idx = torch.arange(t, device=x.device)
        lo = (idx - half).clamp(min=0)
        hi = (idx + half + 1).clamp(max=t)
        return (c[..., hi] - c[..., lo]) / (hi - lo).to(x.dtype)
    x = np.asarray(x)
    c = np.concatenate([np.zeros((*x.shape[:-1], 1), x.dtype), np.cumsum(x, axis=-1)], axis=-1)
    t = x.shape[-1]
    idx = np.arange(t)
    lo = np.clip(idx - half, 0, t)
    hi = np.clip(idx + half + 1, 0, t)
    return (c[..., hi] - c[..., lo]) / (hi - lo)


def joint_positions(poses):
    """FK for numpy or torch poses (..., T, 27) -> (..., T, 10, 3) joint positions (m), differentiably for torch."""
    if not _is_torch(poses):
        return positions_from_pose(poses)
    import torch

    dirs = poses.reshape(*poses.shape[:-1], N_BONES, 3)
    lengths = torch.as_tensor(BONE_LENGTH_ARRAY, dtype=poses.dtype, device=poses.device)
    joints = {"spine": torch.as_tensor(ROOT_POSITION, dtype=poses.dtype, device=poses.device).expand(*poses.shape[:-1], 3)}
    for i, (parent, child) in enumerate(BONES):
        joints[child] = joints[parent] + dirs[..., i, :] * lengths[i]
    return torch.stack([joints[j] for j in JOINTS], dim=-2)


def raw_style(poses, window: int = WINDOW):
    """Un-normalised (speed, space, handedness) per frame: (..., T, 27) -> (..., T, 3)."""
    pos = joint_positions(poses)
    disp = _norm(pos[..., 1:, :, :] - pos[..., :-1, :, :])  # (..., T-1, J)
    # frame 0 has no predecessor: reuse the first displacement so every frame has a value
    first = disp[..., :1, :]
    if _is_torch(disp):
        import torch

        disp = torch.cat([first, disp], dim=-2)
    else:
        disp = np.concatenate([first, disp], axis=-2)
    speed = window_mean(disp.sum(-1), window)
    space = window_mean(_norm(pos[..., _LW, :] - pos[..., _RW, :]), window)
    sl = window_mean(disp[..., _LW], window) + _EPS
    sr = window_mean(disp[..., _RW], window) + _EPS
    if _is_torch(poses):
        import torch

        hand = torch.where(sr > sl, sl / sr - 1.0, 1.0 - sr / sl)
        return torch.stack([speed, space, hand], dim=-1)
    hand = np.where(sr > sl, sl / sr - 1.0, 1.0 - sr / sl)
    return np.stack([speed, space, hand], axis=-1)


@dataclass(frozen=True)
class StyleStats:
    mean: tuple[float, float, float]
    std: tuple[float, float, float]
    source: str = ""

    def normalize(self, raw):
        mean = np.asarray(self.mean, np.float32)
        std = np.asarray(self.std, np.float32)
        if _is_torch(raw):
            import torch

            m = torch.as_tensor(mean, dtype=raw.dtype, device=raw.device)
            s = torch.as_tensor(std, dtype=raw.dtype, device=raw.device)
            return ((raw - m) / s).clamp(-STYLE_LIMIT, STYLE_LIMIT)
        return np.clip((np.asarray(raw) - mean) / std, -STYLE_LIMIT, STYLE_LIMIT)

    def to_json(self) -> str:
        return json.dumps({"names": list(STYLE_NAMES), "mean": list(self.mean), "std": list(self.std), "window": WINDOW, "source": self.source}, indent=2) + "\n"


def fit_stats(motions, source: str = "") -> StyleStats:
    """Mean and standard deviation of the raw statistics over a list of motions (T_i, 27)."""
    raws = np.concatenate([raw_style(np.asarray(m)) for m in motions], axis=0)
    mean = raws.mean(axis=0)
    std = np.maximum(raws.std(axis=0), 1e-4)
    return StyleStats(tuple(float(v) for v in mean), tuple(float(v) for v in std), source)


_loaded: StyleStats | None = None


def load_stats(path: Path | None = None) -> StyleStats:
    """The shipped normalisation statistics (cached)."""
    global _loaded
    if path is None and _loaded is not None:
        return _loaded
    data = json.loads((path or STATS_PATH).read_text())
    if data.get("names") != list(STYLE_NAMES) or data.get("window") != WINDOW:
        raise ValueError(f"{path or STATS_PATH}: style statistics for another layout ({data.get('names')}, window {data.get('window')})")
    stats = StyleStats(tuple(data["mean"]), tuple(data["std"]), data.get("source", ""))
    if path is None:
        _loaded = stats
    return stats


def style(poses, stats: StyleStats | None = None, window: int = WINDOW):
    """Normalised style values in [-3, 3] per frame: (..., T, 27) -> (..., T, 3)."""
    return (stats or load_stats()).normalize(raw_style(poses, window))

"""The flow engine's network: conditional flow matching over windows of poses, in PyTorch.

The regressor of :mod:`model.net` predicts one pose per frame from the speech and averages the
strokes and holds that its teacher varies from take to take. This network *samples* a take
instead: rectified flow (Liu et al. 2022; Lipman et al. 2022) from Gaussian noise ``z`` (T, 27)
to a window of poses, conditioned on the same per-frame inputs as the regressor (audio
features, the word being spoken, the control vector of :data:`core.controls.CONTROL_LAYOUT`).
The seed gives the noise, so a seed still gives one take.

- Poses are standardised per number (``pose_mean``, ``pose_std``: buffers measured on the
  training poses), so the flow runs between two distributions of about unit scale.
- A **condition encoder** (the regressor's input projection and residual dilated convolutions,
  :class:`model.net._Block`) turns the speech and controls into ``hidden`` channels per
  frame, once per window.
- A **denoiser** reads the noisy window, the encoder's channels (added in every block) and
  the flow time ``t`` (a sinusoidal embedding that scales and shifts each block's normalised
  output, FiLM), through residual dilated convolutions.
- It predicts the clean window (x-prediction) with the preconditioning of Karras et al.
  (EDM) written for the rectified-flow path ``x_t = (1 - t) z + t x``: ``x_hat = c_skip x_t +
  c_out F(c_in x_t)``; training weighs each ``t`` alike (:meth:`FlowNet.loss`).
- Frames with a whole-pose control are *replaced* by the requested pose in every prediction,
  so the sampler ends on them exactly; the network learns only the free frames, around them
  (the seed poses of a sliding window are such controls; the free frame after them still starts
  a fresh take, which :func:`model.flow.join` eases in).

:meth:`FlowNet.forward` is the whole sampler, unrolled over the few time points of
``config["times"]`` (Euler steps of the flow: few, because the x-prediction's last step is
already a clean take), with classifier-free guidance on the style controls when
``config["guidance"]`` is not 1. It is what the ONNX export runs, in one call per window.
"""

from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

from core.controls import CONTROL_DIM, control_vector_parts
from core.skeleton import N_BONES, POSE_DIM, REST_POSE
from model.features import AUDIO_DIM, WORD_BUCKETS
from model.net import _Block

DEFAULT_CONFIG = {
    "hidden": 128,
    "word_dim": 32,
    "enc_layers": 4,  # the condition encoder's blocks (dilations 1, 2, 4, 8, ...)
    "layers": 6,  # the denoiser's blocks (dilations 1, 2, 4, 8, 1, 2, ...)
    "kernel": 5,
    "time_dim": 64,
    "times": [0.0, 0.5, 0.8],  # the sampler's time points: one network call each, then t = 1
    "guidance": 1.0,  # classifier-free guidance on the style controls; 1 = off (one pass a step)
    "smooth": 0,  # taps of a binomial low-pass on the sampled free frames; 0 = off
    "noise_dim": POSE_DIM,  # noise numbers per frame (a window draws (T, noise_dim))
}
#: Flow times at or above this are left out of training (``c_out`` vanishes at ``t = 1``).
T_MAX = 0.98
#: Smallest standard deviation a pose number is scaled by (some bone components hardly move).
MIN_STD = 0.01


def _dilations(n: int) -> list[int]:
    return [2 ** (i % 4) for i in range(n)]


class _FlowBlock(nn.Module):
    """A residual dilated convolution that reads the condition channels and the flow time."""

    def __init__(self, channels: int, kernel: int, dilation: int, time_dim: int) -> None:
        super().__init__()
        pad = (kernel - 1) // 2 * dilation
        self.cond = nn.Conv1d(channels, channels, 1)
        self.conv = nn.Conv1d(channels, channels, kernel, padding=pad, dilation=dilation)
        self.norm = nn.GroupNorm(8, channels, affine=False)
        self.film = nn.Linear(time_dim, 2 * channels)
        nn.init.zeros_(self.film.weight)
        nn.init.zeros_(self.film.bias)

    def forward(self, h, cond, temb):
        y = self.norm(self.conv(h + self.cond(cond)))
        scale, shift = self.film(temb)[..., None].chunk(2, dim=1)
        return h + F.silu(y * (1 + scale) + shift)


def time_embedding(t, dim: int):
    """Sinusoidal features (B, dim) of flow times ``t`` (B,) in [0, 1]."""
    half = dim // 2
    freqs = torch.exp(torch.arange(half, dtype=t.dtype, device=t.device) * (-math.log(10000.0) / half))
    args = 1000.0 * t[:, None] * freqs[None]
    return torch.cat([torch.sin(args), torch.cos(args)], dim=-1)


def preconditioning(t):
    """(c_in, c_skip, c_out) of the flow times ``t`` (any shape) for data of unit scale on the
    path ``x_t = (1 - t) z + t x``: the network's input scale, and the clean-window
    prediction ``c_skip x_t + c_out F`` that gives its output F unit scale at every t."""
    var = (1 - t) ** 2 + t**2
    return var.rsqrt(), t / var, (1 - t) * var.rsqrt()


class FlowNet(nn.Module):
    kind = "flow"  # what its weights file records (model.weights.KINDS)

    def __init__(self, config: dict | None = None) -> None:
        super().__init__()
        cfg = {**DEFAULT_CONFIG, **(config or {})}
        cfg["times"] = [float(t) for t in cfg["times"]]
        if not cfg["times"] or cfg["times"][0] != 0.0 or any(b <= a for a, b in zip(cfg["times"], cfg["times"][1:])) \
                or cfg["times"][-1] >= 1.0:
            raise ValueError(f"sampler times must start at 0 and rise below 1, got {cfg['times']}")
        self.config = cfg
        h = cfg["hidden"]
        self.word_emb = nn.Embedding(WORD_BUCKETS, cfg["word_dim"])
        self.inp = nn.Linear(AUDIO_DIM + cfg["word_dim"] + 1 + CONTROL_DIM, h)
        self.encoder = nn.ModuleList(_Block(h, cfg["kernel"], d) for d in _dilations(cfg["enc_layers"]))
        self.time_mlp = nn.Sequential(nn.Linear(cfg["time_dim"], cfg["time_dim"]), nn.SiLU(),
                                      nn.Linear(cfg["time_dim"], cfg["time_dim"]))
        self.x_in = nn.Linear(POSE_DIM, h)
        self.blocks = nn.ModuleList(_FlowBlock(h, cfg["kernel"], d, cfg["time_dim"]) for d in _dilations(cfg["layers"]))
        self.head = nn.Linear(h, POSE_DIM)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)
        self.register_buffer("pose_mean", torch.tensor(REST_POSE, dtype=torch.float32))  # a copy: loading weights writes into it
        self.register_buffer("pose_std", torch.ones(POSE_DIM))

    def set_pose_statistics(self, mean, std) -> None:
        """Standardise poses with the training poses' ``mean`` and ``std`` (27,) from now on."""
        self.pose_mean.copy_(torch.as_tensor(mean, dtype=torch.float32))
        self.pose_std.copy_(torch.as_tensor(std, dtype=torch.float32).clamp_min(MIN_STD))

    def normalise(self, poses):
        return (poses - self.pose_mean) / self.pose_std

    def encode(self, audio, word_ids, onsets, pose, pose_mask, style, style_mask):
        """The condition channels (B, hidden, T) of a batch of windows."""
        controls = control_vector_parts(self.normalise(pose), pose_mask, style, style_mask)
        x = torch.cat([audio, self.word_emb(word_ids), onsets[..., None], *controls], dim=-1)
        x = self.inp(x).transpose(1, 2)
        for block in self.encoder:
            x = block(x)
        return x

    def predict(self, x_t, t, cond, mask, target):
        """The clean window (B, T, 27, standardised) from the noisy ``x_t`` at flow times ``t``
        (B,), with the whole-pose controls ``target`` put in where ``mask`` (B, T, 1) is 1."""
        c_in, c_skip, c_out = (c[:, None, None] for c in preconditioning(t))
        out = self.denoise(c_in * x_t, t, cond)
        x_hat = c_skip * x_t + c_out * out
        return mask * target + (1 - mask) * x_hat

    def denoise(self, x_in, t, cond):
        """The network's raw output F (B, T, 27)."""
        temb = self.time_mlp(time_embedding(t, self.config["time_dim"]))
        h = self.x_in(x_in).transpose(1, 2)
        for block in self.blocks:
            h = block(h, cond, temb)
        return self.head(h.transpose(1, 2))

    def forward(self, audio, word_ids, onsets, pose, pose_mask, style, style_mask, z):
        """Sample poses (B, T, 27) from the noise ``z`` (B, T, 27): all inputs batched (B, T, ...)."""
        cond = self.encode(audio, word_ids, onsets, pose, pose_mask, style, style_mask)
        g = float(self.config["guidance"])
        free_cond = self.encode(audio, word_ids, onsets, pose, pose_mask, style, style_mask * 0) if g != 1.0 else None
        mask = pose_mask[..., None]
        target = self.normalise(pose)
        times = self.config["times"]
        x = z
        for k, t in enumerate(times):
            tt = x.new_full((x.shape[0],), t)
            x_hat = self.predict(x, tt, cond, mask, target)
            if free_cond is not None:  # classifier-free guidance: further from the prediction without the style
                free = self.predict(x, tt, free_cond, mask, target)
                x_hat = free + g * (x_hat - free)
            t_next = times[k + 1] if k + 1 < len(times) else 1.0
            x = x_hat if t_next >= 1.0 else x + (t_next - t) / (1.0 - t) * (x_hat - x)
        taps = int(self.config["smooth"])
        if taps > 1:  # the free frames low-passed, controlled ones kept
            k = torch.tensor([math.comb(taps - 1, i) for i in range(taps)], dtype=x.dtype, device=x.device)
            kernel = (k / k.sum()).repeat(POSE_DIM, 1, 1)
            low = F.conv1d(F.pad(x.transpose(1, 2), (taps // 2, taps // 2), mode="replicate"), kernel, groups=POSE_DIM)
            x = mask * x + (1 - mask) * low.transpose(1, 2)
        b, n, _ = x.shape
        dirs = (x * self.pose_std + self.pose_mean).reshape(b, n, N_BONES, 3)
        dirs = dirs / dirs.norm(dim=-1, keepdim=True).clamp_min(1e-6)
        return dirs.reshape(b, n, POSE_DIM)

    def euler_states(self, cond, mask, target, z, times):
        """The deterministic sampler's states (B, T, 27) at each of ``times`` from the noise ``z``,
        then its clean window (without guidance): len(times) + 1 tensors."""
        x, states = z, []
        for k, t in enumerate(times):
            states.append(x)
            x_hat = self.predict(x, x.new_full((x.shape[0],), t), cond, mask, target)
            t_next = times[k + 1] if k + 1 < len(times) else 1.0
            x = x_hat if t_next >= 1.0 else x + (t_next - t) / (1.0 - t) * (x_hat - x)
        return [*states, x]

    def distill_loss(self, teacher, audio, word_ids, onsets, pose, pose_mask, style, style_mask, z, substeps: int):
        """Few-step distillation (after Salimans & Ho's progressive distillation, in one stage): the
        ``teacher`` (a trained FlowNet) samples from ``z`` with ``substeps`` Euler steps for each
        of this network's sampler steps; at each of its own times this network, given the
        teacher's state there, is trained to predict the clean window whose Euler step lands on
        the teacher's next state (its last step: on the teacher's clean window). The squared
        landing error over the free frames."""
        times = self.config["times"]
        ends = [*times[1:], 1.0]
        fine = [a + (b - a) * j / substeps for a, b in zip(times, ends) for j in range(substeps)]
        mask = pose_mask[..., None]
        target = self.normalise(pose)
        with torch.no_grad():
            cond_t = teacher.encode(audio, word_ids, onsets, pose, pose_mask, style, style_mask)
            path = teacher.euler_states(cond_t, mask, teacher.normalise(pose), z, fine)
            states = [path[k * substeps] for k in range(len(times))] + [path[-1]]
        k = len(times)
        b = z.shape[0]
        cond = self.encode(audio, word_ids, onsets, pose, pose_mask, style, style_mask)
        x = torch.cat(states[:-1])
        t = torch.cat([z.new_full((b,), a) for a in times])
        x_hat = self.predict(x, t, cond.repeat(k, 1, 1), mask.repeat(k, 1, 1), target.repeat(k, 1, 1))
        step = torch.cat([z.new_full((b,), (e - a) / (1.0 - a)) for a, e in zip(times, ends)])[:, None, None]
        land = x + step * (x_hat - x)  # where this network's Euler step lands
        free = (1 - mask).repeat(k, 1, 1)
        err = (land - torch.cat(states[1:])) ** 2 * free
        return err.sum() / (free.sum() * POSE_DIM).clamp_min(1)

    def loss(self, audio, word_ids, onsets, pose, pose_mask, style, style_mask, poses, z, t):
        """The flow-matching loss of a batch: ``poses`` (B, T, 27) the references, ``z`` their
        noise, ``t`` (B,) their flow times. The squared error of F against the output that would
        predict the clean window exactly, over the free frames (controlled frames are replaced),
        which weighs every flow time alike (EDM)."""
        cond = self.encode(audio, word_ids, onsets, pose, pose_mask, style, style_mask)
        x1 = self.normalise(poses)
        tb = t[:, None, None]
        x_t = (1 - tb) * z + tb * x1
        c_in, c_skip, c_out = (c[:, None, None] for c in preconditioning(t))
        out = self.denoise(c_in * x_t, t, cond)
        free = 1 - pose_mask[..., None]
        err = (out - (x1 - c_skip * x_t) / c_out) ** 2 * free
        return err.sum() / (free.sum() * POSE_DIM).clamp_min(1)

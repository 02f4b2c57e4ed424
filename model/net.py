"""The controllable gesture generator (SGToolkit section 4), in PyTorch.

Per frame it sees speech audio features, the word being spoken (hashed embedding and an onset
flag), the control vector of :mod:`core.controls` (pose controls: 27 numbers + mask bit, Eq.
1-2; style controls: 3 values + 3 mask bits, Eq. 3), plus one noise vector per window (a
different seed gives a different take).
It outputs the 27-number pose (unit bone directions).

Architecture (chosen by measurement, see docs/model.md): per-frame inputs are projected to
``hidden`` channels, then a stack of residual dilated 1-D convolutions (non-causal: the whole
window of speech is known) and an optional bidirectional GRU, then a linear head that predicts
an offset from a base pose (the requested pose on controlled frames, the mean pose elsewhere).
With ``smooth`` = k > 0 the free (uncontrolled) frames then go through a fixed k-tap binomial
low-pass along time, inside the network, so every loss (and the discriminator) sees the
smoothed motion: the network cannot buy speed with frame-to-frame jitter, which a per-frame
output layer otherwise leaves and post-hoc smoothing then strips along with the style.
Every bone is renormalised to unit length.
"""

from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

from core.controls import CONTROL_DIM, control_vector_parts
from core.skeleton import N_BONES, POSE_DIM, REST_POSE
from model.features import AUDIO_DIM, WORD_BUCKETS

DEFAULT_CONFIG = {
    "hidden": 128,
    "word_dim": 32,
    "noise_dim": 16,
    "layers": 4,
    "kernel": 5,
    "gru": True,
    "smooth": 5,  # taps of the in-network low-pass on free frames; 0 = off
}


class _Block(nn.Module):
    def __init__(self, channels: int, kernel: int, dilation: int) -> None:
        super().__init__()
        pad = (kernel - 1) // 2 * dilation
        self.conv = nn.Conv1d(channels, channels, kernel, padding=pad, dilation=dilation)
        self.norm = nn.GroupNorm(8, channels)
        self.act = nn.LeakyReLU(0.2)

    def forward(self, x):
        return x + self.act(self.norm(self.conv(x)))


class GestureNet(nn.Module):
    def __init__(self, config: dict | None = None) -> None:
        super().__init__()
        cfg = {**DEFAULT_CONFIG, **(config or {})}
        self.config = cfg
        h = cfg["hidden"]
        self.word_emb = nn.Embedding(WORD_BUCKETS, cfg["word_dim"])
        # per frame: audio features, word embedding, onset flag, the control vector, noise
        in_dim = AUDIO_DIM + cfg["word_dim"] + 1 + CONTROL_DIM + cfg["noise_dim"]
        self.inp = nn.Linear(in_dim, h)
        self.blocks = nn.ModuleList(_Block(h, cfg["kernel"], 2**i) for i in range(cfg["layers"]))
        self.gru = nn.GRU(h, h // 2, batch_first=True, bidirectional=True) if cfg["gru"] else None
        self.head = nn.Linear(h, POSE_DIM)
        self.register_buffer("mean_pose", torch.tensor(REST_POSE, dtype=torch.float32))  # a copy: loading weights writes into it
        taps = int(cfg["smooth"])
        if taps > 1:
            k = torch.tensor([math.comb(taps - 1, i) for i in range(taps)], dtype=torch.float32)
            self.register_buffer("smooth_kernel", (k / k.sum()).repeat(POSE_DIM, 1, 1), persistent=False)
        else:
            self.smooth_kernel = None

    def forward(self, audio, word_ids, onsets, pose, pose_mask, style, style_mask, z):
        """All inputs batched (B, T, ...); ``z`` is (B, noise_dim). Returns poses (B, T, 27)."""
        b, t, _ = audio.shape
        zz = z[:, None, :].expand(b, t, z.shape[-1])
        controls = control_vector_parts(pose, pose_mask, style, style_mask)
        x = torch.cat([audio, self.word_emb(word_ids), onsets[..., None], *controls, zz], dim=-1)
        x = self.inp(x).transpose(1, 2)
        for block in self.blocks:
            x = block(x)
        x = x.transpose(1, 2)
        if self.gru is not None:
            x = x + self.gru(x)[0]
        # Offsets from a base pose: the requested pose on controlled frames, else the mean pose,
        # so following a pose control is the easy default and the network learns the rest.
        m = pose_mask[..., None]
        base = self.mean_pose + m * (pose - self.mean_pose)
        out = self.head(x) + base
        if self.smooth_kernel is not None:
            pad = self.smooth_kernel.shape[-1] // 2
            y = F.pad(out.transpose(1, 2), (pad, pad), mode="replicate")
            low = F.conv1d(y, self.smooth_kernel, groups=POSE_DIM).transpose(1, 2)
            out = m * out + (1 - m) * low
        dirs = out.reshape(b, t, N_BONES, 3)
        dirs = dirs / dirs.norm(dim=-1, keepdim=True).clamp_min(1e-6)
        return dirs.reshape(b, t, POSE_DIM)


class PosteriorEncoder(nn.Module):
    """Training only (not shipped): reads a reference window (poses and velocities) and gives
    the mean and log-variance of a noise vector that explains what the speech cannot, such as
    the speaker's resting hold and beat size (a conditional VAE's posterior). Trained with a KL
    term towards N(0, I), the prior that generation draws the noise from, so each seed is a
    different plausible take instead of the average of all of them."""

    def __init__(self, noise_dim: int, hidden: int = 64) -> None:
        super().__init__()
        self.net = nn.Sequential(
            nn.Conv1d(2 * POSE_DIM, hidden, 5, padding=2), nn.LeakyReLU(0.2),
            nn.Conv1d(hidden, hidden, 5, padding=2, stride=2), nn.LeakyReLU(0.2),
            nn.Conv1d(hidden, hidden, 5, padding=2, stride=2), nn.LeakyReLU(0.2),
        )
        self.out = nn.Linear(hidden, 2 * noise_dim)

    def forward(self, poses):
        vel = torch.diff(poses, dim=1, prepend=poses[:, :1])
        h = self.net(torch.cat([poses, vel], dim=-1).transpose(1, 2)).mean(dim=-1)
        mu, logvar = self.out(h).chunk(2, dim=-1)
        return mu, logvar.clamp(-8.0, 4.0)


class Discriminator(nn.Module):
    """Judges whether a window of poses (and their velocities) looks like the training motion."""

    def __init__(self, hidden: int = 64) -> None:
        super().__init__()
        self.net = nn.Sequential(
            nn.Conv1d(2 * POSE_DIM, hidden, 5, padding=2), nn.LeakyReLU(0.2),
            nn.Conv1d(hidden, hidden, 5, padding=2, stride=2), nn.LeakyReLU(0.2),
            nn.Conv1d(hidden, hidden, 5, padding=2, stride=2), nn.LeakyReLU(0.2),
            nn.Conv1d(hidden, 1, 3, padding=1),
        )

    def forward(self, poses):
        vel = torch.diff(poses, dim=1, prepend=poses[:, :1])
        return self.net(torch.cat([poses, vel], dim=-1).transpose(1, 2)).mean(dim=(1, 2))

"""A training term on the speed histograms that the evaluation compares (Kucherenko et al.).

The regression and velocity terms pull every frame towards the average of what could follow
the speech, so the network moves slowly all the time where its teacher holds still and then
strikes: too few still frames and too few fast ones, which the Hellinger distance of the
joint-speed histograms measures (docs/metrics.md). :func:`soft_speed_hellinger` is that
distance between a batch of generated windows and their reference windows, with each speed
spread over its two nearest bins (triangular weights) so that it has a gradient.
``sgt train --hist-weight W`` adds ``W`` times it to the generator's loss (default 2, the
shipped recipe; 0 switches it off; docs/model.md, "What we compared").
"""

from __future__ import annotations

from core.skeleton import FPS
from model.style import joint_positions
from model.training.metrics import HIST_BIN_WIDTH, HIST_MAX_SPEED


def soft_speed_hellinger(generated, reference, keep=None):
    """Hellinger distance (a scalar tensor) between the joint-speed histograms (m/s, the
    evaluation's bins) of ``generated`` and ``reference`` poses (B, T, 27), pooled over all
    joints and over the windows whose ``keep`` (B,) is 1 (all without it)."""
    import torch

    n_bins = int(round(HIST_MAX_SPEED / HIST_BIN_WIDTH))

    def histogram(poses):
        speed = torch.diff(joint_positions(poses), dim=1).norm(dim=-1) * FPS  # (B, T-1, joints)
        centres = (torch.arange(n_bins, dtype=speed.dtype, device=speed.device) + 0.5) * HIST_BIN_WIDTH
        speed = speed.clamp(float(centres[0]), float(centres[-1]))
        weights = (1.0 - (speed[..., None] - centres).abs() / HIST_BIN_WIDTH).clamp_min(0.0)
        if keep is not None:
            weights = weights * keep[:, None, None, None]
        counts = weights.sum(dim=(0, 1, 2))
        return counts / counts.sum().clamp_min(1e-9)

    overlap = torch.sqrt(histogram(generated) * histogram(reference) + 1e-12).sum()
    return torch.sqrt((1.0 - overlap).clamp_min(1e-9))

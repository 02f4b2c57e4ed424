"""The easing curve of every blend, cross-fade and approach: smoothstep (3x^2 - 2x^3), still
at both ends, never past them."""

from __future__ import annotations

import numpy as np


def smoothstep(x):
    """3x^2 - 2x^3 of ``x`` clipped to [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)

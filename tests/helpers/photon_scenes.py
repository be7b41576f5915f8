"""Small depth scenes for the photon tests."""

from __future__ import annotations

import numpy as np


def disc_scene(rows=64, cols=64, near_m=3.0, far_m=6.0):
    """A disc at ``near_m`` in front of a slanted wall around ``far_m``."""
    yy, xx = np.mgrid[:rows, :cols]
    depth = far_m + 0.01 * xx
    disc = (yy - rows / 2) ** 2 + (xx - cols / 2) ** 2 < (min(rows, cols) / 4) ** 2
    depth[disc] = near_m
    return depth

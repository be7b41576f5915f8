"""Tiny synthetic depth images for the active-learning tests (no dataset needed)."""

from __future__ import annotations

import numpy as np

from spl_al.label_codes import IGNORE_INDEX


def shapes_groups(n: int, n_groups: int = 3, size: int = 16, seed: int = 0, void: float = 0.1):
    """Classification groups: class k is a nearer disk of radius 3 + 2k on a wall.

    Returns depth_m (n, G, size, size) float32 with NaN voids, valid, labels (n,).
    Variants re-draw the noise and voids, as lower photon counts would.
    """
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, 3, n)
    yy, xx = np.mgrid[:size, :size]
    depth = np.empty((n, n_groups, size, size), dtype=np.float32)
    for i in range(n):
        wall = rng.uniform(1.5, 4.0)
        cy, cx = rng.integers(size // 2 - 2, size // 2 + 3, 2)
        disk = (yy - cy) ** 2 + (xx - cx) ** 2 < (3 + 2 * labels[i]) ** 2
        clean = np.where(disk, wall - 0.4, wall)
        for g in range(n_groups):
            depth[i, g] = clean + rng.normal(0, 0.01 * (1 + g), clean.shape)
    depth[rng.random(depth.shape) < void] = np.nan
    return depth, np.isfinite(depth), labels


def street_groups(n: int, n_groups: int = 2, shape=(12, 20), seed: int = 0, void: float = 0.1):
    """Segmentation groups: 0 = ground (lower rows), 1 = box (nearer), 2 = far background.

    Returns depth_m (n, G, H, W) float32 with NaN voids, valid, masks (n, H, W) uint8
    with IGNORE_INDEX at the observed image's voids.
    """
    rng = np.random.default_rng(seed)
    h, w = shape
    yy, xx = np.mgrid[:h, :w]
    depth = np.empty((n, n_groups, h, w), dtype=np.float32)
    masks = np.empty((n, h, w), dtype=np.uint8)
    for i in range(n):
        horizon = rng.integers(h // 2, h - 2)
        x0 = rng.integers(0, w - 6)
        y0 = rng.integers(1, horizon - 2)
        mask = np.where(yy >= horizon, 0, 2)
        box = (xx >= x0) & (xx < x0 + 6) & (yy >= y0) & (yy < horizon)
        mask[box] = 1
        clean = np.select([mask == 0, mask == 1], [2.0 + (h - yy) * 0.5, 5.0], 20.0)
        masks[i] = mask
        for g in range(n_groups):
            depth[i, g] = clean + rng.normal(0, 0.05 * (1 + g), clean.shape)
    depth[rng.random(depth.shape) < void] = np.nan
    valid = np.isfinite(depth)
    masks[~valid[:, 0]] = IGNORE_INDEX
    return depth, valid, masks

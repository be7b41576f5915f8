"""Squared Euclidean distances by one matrix product, on centred features.

    ||x_i - c_j||^2 = |x_i|^2 - 2 x_i . c_j + |c_j|^2

costs one (n, d) x (d, m) product, but each term grows with the features' common
offset while the result does not: features near s + r, with a spread r much smaller
than s, give terms of ~|s|^2 whose float32 sum keeps only the digits above
eps * |s|^2, so a shift of the whole pool changes which point is nearest or farthest.
Distances do not depend on where the origin is, so core-set, k-means and BADGE's
seeding subtract the mean of the rows involved first (``row_mean``, ``centred``),
which leaves terms of the size of the spread.
"""

from __future__ import annotations

import numpy as np


def row_mean(*blocks: np.ndarray) -> np.ndarray:
    """Mean over every row of the (n_b, d) ``blocks`` together: (d,) float64."""
    d = blocks[0].shape[1]
    total = np.zeros(d)
    for b in blocks:
        total += b.sum(axis=0, dtype=np.float64)
    return total / max(sum(len(b) for b in blocks), 1)


def centred(x: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """x - mean as a C-contiguous float32 (n, d) array, subtracted in float64.

    Rounding once, after the subtraction, makes the result for x + s (the shift exact
    in float32, the mean taken over the same rows) the same array as for x, up to the
    float64 rounding of the mean: the offset leaves no trace.
    """
    out = np.empty(np.shape(x), dtype=np.float32)
    np.subtract(x, mean, out=out, dtype=np.float64, casting="same_kind")
    return out


def sq_distances(
    x: np.ndarray, x_sq: np.ndarray, c: np.ndarray, c_sq: np.ndarray | None = None
) -> np.ndarray:
    """||x_i - c_j||^2 = |x_i|^2 - 2 x_i . c_j + |c_j|^2, clipped at 0: (len(x), len(c)).

    Args:
        x: (n, d) and c: (m, d) float32 points, centred (see the module docstring).
        x_sq: (n,) squared row norms of x; c_sq: (m,) those of c, or None to compute.
    """
    if c_sq is None:
        c_sq = np.einsum("ij,ij->i", c, c)
    d2 = x @ np.ascontiguousarray(c.T)  # a contiguous right operand is ~2x faster here
    d2 *= -2.0
    d2 += x_sq[:, None]
    d2 += c_sq[None]
    return np.maximum(d2, 0.0, out=d2)


def unit_rows(x) -> np.ndarray:
    """Each row of the (n, d) ``x`` divided by its L2 norm, float32 (a zero row stays
    zero): the features TypiClust, ProbCover and MaxHerding select on, as their
    reference code loads them (scale-free: only a feature vector's direction counts)."""
    x = np.asarray(x, dtype=np.float64)
    norm = np.linalg.norm(x, axis=1, keepdims=True)
    return np.ascontiguousarray(x / np.where(norm > 0, norm, 1.0), dtype=np.float32)


def pool_features(inputs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The whole pool's unit-length features in training-set order, which rows are
    labeled, and each row's position in ``inputs.unlabeled_idx`` (-1 for a labeled one):
    ((n, d) float32, (n,) bool, (n,) int64), n = labeled + unlabeled.

    The order is the training set's, not "labeled first": a k-means seeded alike then
    meets the same rows in the same order every round, whichever are labeled.
    """
    n_lab, n_unl = len(inputs.labeled_idx), len(inputs.unlabeled_idx)
    idx = np.concatenate([inputs.labeled_idx, inputs.unlabeled_idx])
    unl = np.asarray(inputs.features)
    lab = np.asarray(inputs.labeled_features).reshape(n_lab, unl.shape[1])
    feats = np.concatenate([lab, unl])
    position = np.concatenate([np.full(n_lab, -1), np.arange(n_unl)]).astype(np.int64)
    order = np.argsort(idx, kind="stable")
    return unit_rows(feats[order]), position[order] < 0, position[order]


def euclidean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distances (len(a), len(b)) of float32 rows (``sq_distances`` on rows
    centred by their joint mean)."""
    mean = row_mean(a, b)
    ac, bc = centred(a, mean), centred(b, mean)
    return np.sqrt(sq_distances(ac, np.einsum("ij,ij->i", ac, ac), bc))

"""Reductions over task units and ranking rules shared by the strategies.

A *unit* is what one prediction is about: the image itself for classification
(one unit), a pixel for segmentation. Arrays of per-unit values are shaped
(groups, units); ``valid`` (groups, units) marks the units that count.
"""

from __future__ import annotations

import numpy as np


def unit_mean(values: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
    """Mean over the valid units of each group: (groups, units) -> (groups,).

    A group without any valid unit gets NaN (strategies rank NaN last).
    """
    values = np.asarray(values)
    if valid is None:
        return values.mean(axis=1) if values.shape[1] else np.full(len(values), np.nan)
    valid = np.asarray(valid, dtype=bool)
    if valid.shape != values.shape:
        raise ValueError(
            f"valid must have shape (groups, units) = {values.shape}, got {valid.shape}."
        )
    count = valid.sum(axis=1)
    total = np.where(valid, values, 0).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def check_probs(probs, ndim: int, name: str = "probs") -> np.ndarray:
    """probs as float64, checking its number of dimensions and at least 2 classes."""
    p = np.asarray(probs, dtype=np.float64)
    if p.ndim != ndim or p.shape[-1] < 2:
        raise ValueError(
            f"{name} must be {ndim}-D with >= 2 classes on the last axis, got {p.shape}."
        )
    return p


def top_gap(probs: np.ndarray) -> np.ndarray:
    """Difference between the largest and second-largest entry on the last axis."""
    top2 = np.partition(probs, -2, axis=-1)[..., -2:]
    return top2[..., 1] - top2[..., 0]


def top_k(scores, k: int, rng: np.random.Generator) -> np.ndarray:
    """Positions of the ``k`` highest scores, best first.

    Exact ties are broken uniformly at random with ``rng``; NaN ranks below every
    number. ``k`` larger than the number of scores returns them all.
    """
    s = np.asarray(scores, dtype=np.float64)
    s = np.where(np.isnan(s), -np.inf, s)
    order = np.lexsort((rng.permutation(len(s)), -s))  # last key is primary
    return order[: min(int(k), len(s))]


def check_points(x, name: str = "features") -> np.ndarray:
    """A non-empty (n, d) float32 array of points, C-contiguous."""
    a = np.ascontiguousarray(x, dtype=np.float32)
    if a.ndim != 2 or len(a) == 0:
        raise ValueError(f"{name} must be a non-empty (n, d) array, got shape {a.shape}.")
    return a

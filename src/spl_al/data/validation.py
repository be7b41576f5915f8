"""The validation split: part of the training pool held out for tuning recipes, so
that benches which fit and score a recipe never read the test split."""

from __future__ import annotations

import numpy as np

from spl_al.data.seeds import STREAM_VALIDATION, sample_rng

VALIDATION_FRACTION = 0.2  # of the training pool (of each class for classification)
VALIDATION_SEED = 0


def validation_split(
    train_idx, fraction: float = VALIDATION_FRACTION, seed: int = VALIDATION_SEED, labels=None
) -> tuple[np.ndarray, np.ndarray]:
    """(fit_idx, val_idx): the training pool ``train_idx`` cut in two, both ascending.

    ``round(fraction * n_c)`` random members of each class c go to validation (of the
    whole pool when ``labels`` is None, e.g. for segmentation), drawn from ``seed``'s
    own stream: the same pool and seed give the same split, whatever the pool's order.

    Args:
        train_idx: (N,) distinct sample indices of the training split.
        fraction: share of the pool (of each class) held out, in (0, 1).
        seed: non-negative integer seed of the draw.
        labels: (N,) class of each member of ``train_idx`` (not of the whole
            dataset), or None for an unstratified split.
    """
    idx = np.asarray(train_idx)
    if idx.ndim != 1 or not np.issubdtype(idx.dtype, np.integer):
        raise ValueError(f"train_idx must be a 1-D integer array, got {idx.dtype} {idx.shape}.")
    if np.unique(idx).size != idx.size:
        raise ValueError("train_idx must not repeat an index.")
    if not 0 < fraction < 1:
        raise ValueError(f"fraction must be in (0, 1), got {fraction!r}.")
    n = idx.size
    if labels is None:
        code = np.zeros(n, dtype=np.int64)
    else:
        y = np.asarray(labels)
        if y.shape != (n,):
            raise ValueError(f"labels must have shape ({n},) like train_idx, got {y.shape}.")
        code = np.unique(y, return_inverse=True)[1].reshape(n)
    ascending = np.argsort(idx, kind="stable")  # the draw ignores the pool's order
    idx, code = idx[ascending], code[ascending]
    rng = sample_rng(seed, STREAM_VALIDATION)
    order = rng.permutation(n)  # random order within each class
    by_class = order[np.argsort(code[order], kind="stable")]
    counts = np.bincount(code)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    rank = np.empty(n, dtype=np.int64)
    rank[by_class] = np.arange(n) - starts[code[by_class]]
    held = rank < np.rint(fraction * counts).astype(np.int64)[code]
    if not held.any() or held.all():
        raise ValueError(
            f"fraction {fraction} of a pool of {n} leaves its fit or validation part empty."
        )
    return idx[~held].astype(np.int64), idx[held].astype(np.int64)

"""Core-set selection (Sener & Savarese 2018): k-center greedy on penultimate features."""

from __future__ import annotations

import numpy as np

from spl_al.strategies.base import Strategy, register
from spl_al.strategies.distances import centred, row_mean, sq_distances
from spl_al.strategies.inputs import StrategyInputs

# rows of the labeled block per distance chunk: chunk memory ~ n_unlabeled * this * 4 bytes
_CHUNK_ELEMENTS = 1 << 23


def k_center_greedy(features, labeled_features, k: int, rng: np.random.Generator) -> np.ndarray:
    """Greedy k-center: repeatedly pick the point farthest from all chosen centres.

    Centres start as the labeled set; each pick is ``argmax_i min_j ||x_i - c_j||``
    over the unlabeled points, after which it becomes a centre. Only the vector of
    minimum squared distances (n,) is kept and updated with one (n, d) pass per pick:
    O(n d) memory and O((m + k) n d) time, never an n x n matrix. Distances are
    |x_i|^2 - 2 x_i . c_j + |c_j|^2 after subtracting the mean of all n + m rows
    (``spl_al.strategies.distances``).

    Args:
        features: (n, d) unlabeled features.
        labeled_features: (m, d) labeled features (m may be 0).
        k: number of picks (<= n).
        rng: breaks exact ties (and picks the first centre when m = 0).

    Returns:
        (k,) distinct positions into ``features`` in pick order.
    """
    x = np.asarray(features, dtype=np.float32)
    if x.ndim != 2:
        raise ValueError(f"features must be (n, d), got shape {x.shape}.")
    lab = np.asarray(labeled_features, dtype=np.float32).reshape(-1, x.shape[1])
    n = len(x)
    if not 0 <= k <= n:
        raise ValueError(f"k must be in [0, {n}], got {k}.")
    mean = row_mean(x, lab)
    x, lab = centred(x, mean), centred(lab, mean)
    sq = np.einsum("ij,ij->i", x, x)
    min_d2 = np.full(n, np.inf, dtype=np.float32)
    chunk = max(1, _CHUNK_ELEMENTS // max(n, 1))
    for start in range(0, len(lab), chunk):
        min_d2 = np.minimum(min_d2, sq_distances(x, sq, lab[start : start + chunk]).min(axis=1))
    picks = np.empty(k, dtype=np.int64)
    for t in range(k):
        best = np.flatnonzero(min_d2 == min_d2.max())
        pick = best[0] if len(best) == 1 else rng.choice(best)
        picks[t] = pick
        min_d2 = np.minimum(min_d2, sq_distances(x, sq, x[pick : pick + 1])[:, 0])
        min_d2[pick] = -np.inf  # chosen: never again
    return picks


@register
class CoresetStrategy(Strategy):
    """k-center greedy over the observed images' features, starting from the labeled set."""

    name = "coreset"
    needs = frozenset({"features", "labeled_features"})

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        return k_center_greedy(inputs.features, inputs.labeled_features, k, rng)

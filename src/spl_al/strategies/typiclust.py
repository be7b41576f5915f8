"""TypiClust (Hacohen, Dekel and Weinshall, "Active Learning on a Budget", ICML 2022),
as its reference code (github.com/avihu111/TypiClust, ``typiclust.py``) runs it.

1. The pool's features (labeled and unlabeled) are L2-normalised and clustered by
   k-means into min(|L| + B, 500) clusters (|L| labeled, B the batch).
2. Clusters of ``min_cluster_size`` (5) samples or fewer are dropped.
3. Clusters are visited by fewest labeled samples, then by largest size, round-robin
   until B samples are picked.
4. In each visited cluster the pick is the unlabeled, not yet picked sample of highest
   typicality among the cluster's remaining unlabeled samples::

       typicality(x) = 1 / mean_{x_i in kNN(x)} ||x - x_i||,   K = min(20, m // 2)

   for m of them (the paper's equation; the reference code averages squared
   distances from faiss instead, which can order two samples differently).

Against scikit-activeml's ``TypiClust`` (which spl-al ran before): the features are
normalised, K is the paper's 20 instead of 5, small clusters are dropped, and K shrinks
with the cluster. The k-means is spl-al's own (``spl_al.strategies.kmeans``, one
k-means++ start seeded by the round) instead of scikit-learn's.
"""

from __future__ import annotations

import numpy as np

from spl_al.strategies.base import Strategy, register
from spl_al.strategies.distances import euclidean, pool_features
from spl_al.strategies.inputs import StrategyInputs
from spl_al.strategies.kmeans import unit_clusters


def typicality(x: np.ndarray, k_nn: int) -> np.ndarray:
    """1 / (mean Euclidean distance to the ``k_nn`` nearest other rows + 1e-5), (m,),
    of the (m, d) rows ``x`` (1 for a single row)."""
    m = len(x)
    k = min(int(k_nn), m // 2)
    if k < 1:
        return np.ones(m)
    d = euclidean(x, x).astype(np.float64)
    np.fill_diagonal(d, np.inf)
    nearest = np.partition(d, k - 1, axis=1)[:, :k]
    return 1.0 / (nearest.mean(axis=1) + 1e-5)


@register
class TypiClustStrategy(Strategy):
    """The most typical sample of the least-labeled, largest clusters (module docstring).

    Args:
        k_nn: neighbours of the typicality (the paper's 20, at most half a cluster).
        min_cluster_size: clusters of this many samples or fewer are dropped (5).
        max_clusters: the most clusters k-means makes (500).
    """

    name = "typiclust"
    needs = frozenset({"features", "labeled_features"})

    def __init__(self, k_nn: int = 20, min_cluster_size: int = 5, max_clusters: int = 500):
        for key, value, low in (
            ("k_nn", k_nn, 1),
            ("min_cluster_size", min_cluster_size, 0),
            ("max_clusters", max_clusters, 1),
        ):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
                raise ValueError(f"typiclust: {key} must be an integer >= {low}, got {value!r}.")
        self.k_nn = int(k_nn)
        self.min_cluster_size = int(min_cluster_size)
        self.max_clusters = int(max_clusters)

    def params(self) -> dict:
        """The strategy's parameters, as recorded with its results."""
        return {
            "k_nn": self.k_nn,
            "min_cluster_size": self.min_cluster_size,
            "max_clusters": self.max_clusters,
        }

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        x, labeled, position = pool_features(inputs)
        n_clusters = min(int(labeled.sum()) + k, self.max_clusters, len(x))
        cluster = unit_clusters(x, n_clusters, rng=rng)
        sizes = np.bincount(cluster, minlength=n_clusters)
        labeled_in = np.bincount(cluster[labeled], minlength=n_clusters)
        kept = np.flatnonzero(sizes > self.min_cluster_size)
        # fewest labeled first, then the largest (stable: lower cluster id on ties)
        kept = kept[np.lexsort((-sizes[kept], labeled_in[kept]))]
        self.decision = {
            "clusters": int(n_clusters),
            "clusters_used": len(kept),
            "clusters_dropped": int(n_clusters - len(kept)),
            "k_nn": self.k_nn,
        }
        open_ = ~labeled  # unlabeled and not yet picked
        picks: list[int] = []
        visiting, at = list(kept), 0
        while len(picks) < k and visiting:
            at %= len(visiting)
            members = np.flatnonzero(open_ & (cluster == visiting[at]))
            if not len(members):  # used up: the next cluster takes its turn
                visiting.pop(at)
                continue
            best = members[int(np.argmax(typicality(x[members], self.k_nn)))]
            picks.append(int(position[best]))
            open_[best] = False
            at += 1
        if len(picks) < k:  # every cluster dropped or used up: the rest uniformly
            self.decision["random_picks"] = int(k - len(picks))
            rest = np.setdiff1d(np.arange(inputs.n_unlabeled), picks)
            picks += rng.choice(rest, size=k - len(picks), replace=False).tolist()
        return np.asarray(picks, dtype=np.int64)

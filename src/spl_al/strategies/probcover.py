"""ProbCover (Yehuda, Dekel, Hacohen and Weinshall, "Active Learning Through a Covering
Lens", NeurIPS 2022), as its reference code (github.com/avihu111/TypiClust,
``prob_cover.py``) runs it.

On the pool's L2-normalised features (labeled and unlabeled):

1. **The radius delta, once per representation.** k-means into ``n_classes``
   clusters (the task's class count, no label) gives pseudo-labels; a ball B(x, delta)
   = {y : ||x - y|| < delta} is pure when every sample in it shares x's cluster, and
   delta is the largest radius whose balls are pure for at least ``purity`` (0.95) of
   the samples. The k-means is seeded by ``seed``, not by the round: the same features
   give the same delta in every round (the embedding framework's encoder is fixed, so
   a run has one delta; the supervised framework's features change with the model).
   delta is computed exactly: with r_i the distance from x_i to the nearest sample of
   another cluster, B(x_i, delta) is pure iff r_i >= delta, so delta is the
   floor(n (1 - purity))-th smallest r_i, not a point of a grid.
2. **Greedy max coverage.** Every sample within delta of a labeled one is covered;
   each pick is the unlabeled sample whose ball holds the most uncovered samples (ties
   at random), whose ball's samples are then covered.
3. **Full coverage.** When no ball holds an uncovered sample, the rest of the batch is
   drawn uniformly from the unpicked unlabeled samples (the paper's fallback), and the
   round's record says how many.

Against scikit-activeml's ``ProbCover`` (which spl-al ran before): the features are
normalised, delta is exact instead of the best of a fixed grid 0.2..2.0 in raw
units, it is the same in every round, and the record keeps delta, the purity at delta
and the coverage before and after the query.
"""

from __future__ import annotations

import numpy as np

from spl_al.strategies.base import Strategy, register
from spl_al.strategies.distances import euclidean, pool_features
from spl_al.strategies.inputs import StrategyInputs
from spl_al.strategies.kmeans import unit_clusters

# rows of one distance block (float32 rows x pool)
_BLOCK_ROWS = 1024
MISSING_CLASSES = (
    "probcover needs n_classes, the task's class count (the k-means its radius is chosen "
    "on), e.g. params: {n_classes: 11}."
)


def purity_radius(x: np.ndarray, clusters: np.ndarray, purity: float) -> tuple[float, float]:
    """(delta, the share of pure balls at delta) for (n, d) rows ``x`` and their
    ``clusters`` (n,): delta the largest radius whose open balls are pure for at least
    ``purity`` of the rows (module docstring). One cluster: every ball is pure, and delta
    is the pool's diameter."""
    n = len(x)
    nearest_other = np.full(n, np.inf)
    for s in range(0, n, _BLOCK_ROWS):
        d = euclidean(x[s : s + _BLOCK_ROWS], x).astype(np.float64)
        d[clusters[s : s + _BLOCK_ROWS, None] == clusters[None]] = np.inf
        nearest_other[s : s + _BLOCK_ROWS] = d.min(axis=1)
    if np.isinf(nearest_other).all():
        delta = float(max(euclidean(x, x).max(), 1e-6)) * (1 + 1e-6)
        return delta, 1.0
    delta = float(np.sort(nearest_other)[int(np.floor(n * (1.0 - purity)))])
    return delta, float(np.mean(nearest_other >= delta))


def ball_graph(x: np.ndarray, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """The pool's balls as compressed rows (``indptr`` (n + 1,), ``indices``): row i
    lists the samples j with ||x_i - x_j|| < delta (i itself when delta > 0). The
    relation is made exactly symmetric (a pair at the boundary counts only if both of
    its rounded distances fall inside), so row j also lists the balls that hold j."""
    n = len(x)
    inside = np.zeros((n, n), dtype=bool)
    for s in range(0, n, _BLOCK_ROWS):
        inside[s : s + _BLOCK_ROWS] = euclidean(x[s : s + _BLOCK_ROWS], x) < delta
    inside &= inside.T
    indptr = np.concatenate([[0], np.cumsum(inside.sum(axis=1))]).astype(np.int64)
    return indptr, np.nonzero(inside)[1].astype(np.int64)


@register
class ProbCoverStrategy(Strategy):
    """Greedy coverage of the pure-ball radius delta (module docstring).

    Args:
        n_classes: the task's class count, the k of the purity k-means (not a label);
            a selection without it is refused (``required``).
        purity: the share of pure balls delta keeps (the paper's 0.95), in (0, 1).
        seed: seed of the purity k-means (the same in every round).
    """

    name = "probcover"
    needs = frozenset({"features", "labeled_features"})
    required = ("n_classes",)

    def __init__(self, n_classes: int | None = None, purity: float = 0.95, seed: int = 0):
        bad = isinstance(n_classes, bool) or not isinstance(n_classes, int | np.integer)
        if n_classes is not None and (bad or n_classes < 1):
            raise ValueError(f"probcover: n_classes must be an integer >= 1, got {n_classes!r}.")
        if isinstance(purity, bool) or not isinstance(purity, int | float) or not 0 < purity < 1:
            raise ValueError(f"probcover: purity must lie in (0, 1), got {purity!r}.")
        self.n_classes = None if n_classes is None else int(n_classes)
        self.purity = float(purity)
        self.seed = int(seed)

    def params(self) -> dict:
        """The strategy's parameters, as recorded with its results."""
        return {"n_classes": self.n_classes, "purity": self.purity, "seed": self.seed}

    def radius(self, x: np.ndarray) -> tuple[float, float]:
        """(delta, purity at delta) of the pool's unit-length features ``x`` (n, d)."""
        if self.n_classes is None:
            raise ValueError(MISSING_CLASSES)
        k = min(self.n_classes, len(x))
        clusters = unit_clusters(x, k, rng=np.random.default_rng(self.seed))
        return purity_radius(x, clusters, self.purity)

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        x, labeled, position = pool_features(inputs)
        delta, purity = self.radius(x)
        indptr, indices = ball_graph(x, delta)

        def ball(i):
            return indices[indptr[i] : indptr[i + 1]]

        covered = np.zeros(len(x), dtype=bool)
        for i in np.flatnonzero(labeled):
            covered[ball(i)] = True
        before = float(covered.mean())
        # degree[i]: uncovered samples in ball i
        uncovered_at = np.repeat(np.arange(len(x)), np.diff(indptr))[~covered[indices]]
        degree = np.bincount(uncovered_at, minlength=len(x))
        open_ = ~labeled
        picks: list[int] = []
        while len(picks) < k:
            score = np.where(open_, degree, -1)
            top = score.max()
            if top <= 0:
                break
            best = np.flatnonzero(score == top)
            row = int(best[rng.integers(len(best))]) if len(best) > 1 else int(best[0])
            picks.append(row)
            open_[row] = False
            for j in ball(row)[~covered[ball(row)]]:  # newly covered: every ball holding
                degree[ball(j)] -= 1  # j (the relation is symmetric) loses one
            covered[ball(row)] = True
        self.decision = {
            "delta": round(delta, 6),
            "purity": round(purity, 4),
            "coverage_before": round(before, 4),
            "coverage_after": round(float(covered.mean()), 4),
        }
        positions = position[picks].tolist()
        if len(positions) < k:  # full coverage: the rest uniformly (the paper's fallback)
            self.decision["random_picks"] = int(k - len(positions))
            rest = np.setdiff1d(np.arange(inputs.n_unlabeled), positions)
            positions += rng.choice(rest, size=k - len(positions), replace=False).tolist()
        return np.asarray(positions, dtype=np.int64)

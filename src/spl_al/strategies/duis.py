"""DUIS, the paper's Algorithm 2: diversity-constrained, condition-aware acquisition.

1. phi_i = mean_m phi(I_i^(m)): group features averaged over the M+1 images.
2. k-means with N_cand clusters over {phi_i} of the unlabeled pool; the group
   nearest each centre (each group used once) forms the candidate pool C. N_cand
   may be at most half the unlabeled pool (``MAX_CAND_FRACTION``): C must stay a
   diverse subset of the pool, not most of it.
3. For each candidate, over its task units u, with q_m(u) the class probabilities
   of image m and qbar(u) = mean_m q_m(u):
       gamma_i = mean_u [ qbar(u, top1) - qbar(u, top2) ]       (small = uncertain)
       d_i     = mean_u mean_m KL( q_m(u) || qbar(u) )          (inconsistency)
4. Min-max normalise within C: x~ = (x - min x) / (max x - min x + eps).
5. UIS_alpha = alpha * d~ + (1 - alpha) * (1 - gamma~); query the top N_batch of C.
"""

from __future__ import annotations

import numpy as np

from spl_al.strategies.base import Strategy, register
from spl_al.strategies.distances import centred, row_mean, sq_distances
from spl_al.strategies.inputs import StrategyInputs
from spl_al.strategies.kmeans import kmeans
from spl_al.strategies.units import check_points, check_probs, top_gap, top_k, unit_mean

# elements of the centres x points distance block computed at once (float32: 32 MB)
_CHUNK_ELEMENTS = 1 << 23
# N_cand may be at most this share of the unlabeled pool the candidates are drawn
# from: a k-means pool of most of the pool is no longer a diverse subset of it.
MAX_CAND_FRACTION = 0.5


class CandidatePoolTooLarge(ValueError):
    """N_cand is more than ``MAX_CAND_FRACTION`` of the unlabeled pool of a query."""

    def __init__(self, message: str, n_cand: int, n_unlabeled: int):
        super().__init__(message)
        self.n_cand, self.n_unlabeled = int(n_cand), int(n_unlabeled)


def n_cand_error(
    n_cand: int,
    n_unlabeled: int,
    *,
    round_: int | None = None,
    dataset: str | None = None,
    method: str | None = None,
    seed: int | None = None,
    key: str | None = None,
    fraction: float = MAX_CAND_FRACTION,
) -> str | None:
    """The one-sentence error when N_cand is more than ``fraction`` (a half) of the
    ``n_unlabeled`` groups a query draws from (the query that makes round ``round_``
    of ``dataset``/``method``, seed ``seed``), else None. ``key``: what to set
    (default ``datasets.{dataset}.method_params.{method}.n_cand``)."""
    if n_cand <= fraction * n_unlabeled:
        return None
    limit = int(fraction * n_unlabeled)
    share = "half" if fraction == 0.5 else f"{fraction:.0%}"
    who = f"{dataset}/{method}" if dataset and method else (method or "")
    if who and seed is not None:
        who += f" seed {seed}"
    query = "the query" if round_ is None else f"the query that makes round {round_}"
    if key is None:
        key = (
            f"datasets.{dataset}.method_params.{method}.n_cand" if dataset and method else "n_cand"
        )
    return (
        f"{who + ': ' if who else ''}{query} draws a k-means candidate pool of "
        f"N_cand = {n_cand} from {n_unlabeled} unlabeled groups "
        f"({n_cand / max(n_unlabeled, 1):.0%}, more than {share} of them: no longer a "
        f"diverse subset); set {key} <= {limit}."
    )


def margin_and_inconsistency(probs, valid=None, image_valid=None) -> tuple[np.ndarray, np.ndarray]:
    """DUIS's margin gamma and inconsistency d of each group (steps 3 above).

    Args:
        probs: (groups, M+1, units, classes) class probabilities of every image of each
            group (observed first; one unit per image for classification).
        valid: optional (groups, units) bool mask of the units that count (for
            segmentation: the observed image's valid pixels, where the label applies).
        image_valid: optional (groups, M+1, units) bool mask of the units each image
            holds (segmentation: a variant's void pixels carry no prediction).

    Returns:
        gamma, d: (groups,) float64. With V_m the units valid in image m (V_0 = ``valid``
        when given) and qbar(u) the mean of q_m(u) over the images m with u in V_m:

            gamma = mean_{u in V_0} [ qbar(u, top1) - qbar(u, top2) ]
            d     = mean_m  mean_{u in V_m and V_0}  KL( q_m(u) || qbar(u) )

        with KL(q || qbar) = sum_c q_c log(q_c / qbar_c) (terms with q_c = 0 are 0), and
        the outer mean over the images that hold at least one such unit. Without
        ``image_valid`` every image holds every unit (classification; the paper's
        equations). A group without valid units gets NaN for both.

        Point clouds (PointNet++, ``arch: pointnet2``): the units are pixels and the
        points of image m are its valid pixels V_m, each point keeping its pixel
        index, so with P_m the point set of image m (P_0 the observed cloud) the same
        equations read, per group,

            qbar(u)  = mean_{m : u in P_m} q_m(u)                       (u in P_0)
            gamma    = mean_{u in P_0} [ qbar(u, top1) - qbar(u, top2) ]
            d        = mean_m  mean_{u in P_m and P_0}  KL( q_m(u) || qbar(u) )

        (margin over the observed cloud's points; a variant's KL over the points it
        shares with the observed cloud; qbar over the images that have the point).
        tests/test_pointnet.py checks a hand-computed case.
    """
    p = check_probs(probs, 4)
    g, n_images, n_units, _ = p.shape
    if image_valid is None:
        held = np.ones((g, n_images, n_units), dtype=bool)
    else:
        held = np.asarray(image_valid, dtype=bool)
        if held.shape != p.shape[:3]:
            raise ValueError(
                f"image_valid must have shape (groups, M+1, units) = {p.shape[:3]}, "
                f"got {held.shape}."
            )
    if valid is None:
        valid = held[:, 0] if image_valid is not None else None
    counted = held if valid is None else held & np.asarray(valid, dtype=bool)[:, None]
    # qbar over the images that hold the unit (all of them where none does)
    n_held = held.sum(axis=1, keepdims=True)  # (groups, 1, units)
    weight = np.where(n_held > 0, held / np.maximum(n_held, 1), 1.0 / n_images)
    qbar = np.einsum("gmu,gmuc->guc", weight, p)  # (groups, units, C)
    gamma = unit_mean(top_gap(qbar), valid)
    # q_m > 0 at a held unit implies qbar > 0 there, so the logs below are finite where used
    positive = (p > 0) & held[..., None]
    log_ratio = np.log(np.where(positive, p, 1.0)) - np.log(
        np.where(positive, np.broadcast_to(qbar[:, None], p.shape), 1.0)
    )
    kl = np.maximum(np.sum(np.where(positive, p * log_ratio, 0.0), axis=-1), 0.0)
    per_image = unit_mean(kl.reshape(g * n_images, n_units), counted.reshape(g * n_images, -1))
    d = unit_mean(
        np.nan_to_num(per_image.reshape(g, n_images)), ~np.isnan(per_image).reshape(g, -1)
    )
    return gamma, d


def _min_max(x: np.ndarray, eps: float) -> np.ndarray:
    if x.size == 0:
        return x
    return (x - np.nanmin(x)) / (np.nanmax(x) - np.nanmin(x) + eps)


def uis(gamma, d, alpha: float = 0.5, eps: float = 1e-8) -> np.ndarray:
    """UIS_alpha = alpha * d~ + (1 - alpha) * (1 - gamma~), min-max normalised over the arrays.

    Args:
        gamma, d: (n,) margins and inconsistencies of the candidate pool.
        alpha: weight of inconsistency in [0, 1] (0: uncertainty only).
        eps: > 0, added to the normalisers' denominators (all-equal values give x~ = 0).

    Returns:
        (n,) float64 scores, higher = more informative; NaN where an input is NaN.
    """
    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha must be in [0, 1], got {alpha!r}.")
    if not eps > 0:
        raise ValueError(f"eps must be > 0, got {eps!r}.")
    g = np.asarray(gamma, dtype=np.float64)
    dd = np.asarray(d, dtype=np.float64)
    if g.ndim != 1 or g.shape != dd.shape:
        raise ValueError(f"gamma and d must be 1-D of equal length, got {g.shape} and {dd.shape}.")
    if g.size and np.isnan(g).all():
        return np.full(g.shape, np.nan)
    return alpha * _min_max(dd, eps) + (1.0 - alpha) * (1.0 - _min_max(g, eps))


def nearest_unique(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """For each centre a distinct point, as near to it as possible: (n_centres,) positions.

    Centres are served in order of their nearest distance (closest first, stable);
    each takes its nearest point not yet taken. Only each centre's n_centres nearest
    points are kept (enough, as at most n_centres - 1 are taken before it). Distances
    are taken after subtracting the points' mean from both (``spl_al.strategies.distances``).

    Args:
        points: (n, d); centres: (n_centres, d), n_centres <= n. Centres are centred
            in their own precision, so float64 centres near an offset keep their digits.
    """
    x = check_points(points, "points")
    n, m = len(x), len(check_points(centres, "centres"))
    if m > n:
        raise ValueError(f"cannot give {m} centres distinct points out of {n}.")
    mean = row_mean(x)
    x, c = centred(x, mean), centred(np.asarray(centres), mean)
    x_sq = np.einsum("ij,ij->i", x, x)
    near_idx = np.empty((m, m), dtype=np.int64)
    near_d2 = np.empty((m, m), dtype=np.float32)
    rows = max(1, _CHUNK_ELEMENTS // n)
    for s in range(0, m, rows):
        cc = c[s : s + rows]
        d2 = sq_distances(cc, np.einsum("ij,ij->i", cc, cc), x, x_sq)  # (rows, n)
        part = (
            np.argpartition(d2, m - 1, axis=1)[:, :m]
            if m < n
            else np.tile(np.arange(n), (len(cc), 1))
        )
        pd = np.take_along_axis(d2, part, axis=1)
        order = np.lexsort((part, pd), axis=1)  # by distance, then by position
        near_idx[s : s + rows] = np.take_along_axis(part, order, axis=1)
        near_d2[s : s + rows] = np.take_along_axis(pd, order, axis=1)
    taken = np.zeros(n, dtype=bool)
    out = np.empty(m, dtype=np.int64)
    for j in np.argsort(near_d2[:, 0], kind="stable"):
        for i in near_idx[j]:
            if not taken[i]:
                taken[i] = True
                out[j] = i
                break
    return out


def candidate_pool(
    features, n_cand: int, rng: np.random.Generator, max_iter: int = 100
) -> np.ndarray:
    """DUIS's candidate pool: the group nearest each of N_cand k-means centres.

    Args:
        features: (n, d) group features phi_i of the unlabeled pool.
        n_cand: N_cand; a pool of n <= N_cand groups is returned whole.
        rng: seeds k-means (greedy k-means++ initialisation, one run).
        max_iter: Lloyd iterations at most.

    Returns:
        (min(n_cand, n),) distinct positions into ``features``.
    """
    x = check_points(features, "group_features")
    n = len(x)
    if n_cand >= n:
        return np.arange(n)
    return nearest_unique(x, kmeans(x, n_cand, rng=rng, max_iter=max_iter))


@register
class DUISStrategy(Strategy):
    """DUIS: k-means candidate pool on group features, ranked by UIS_alpha.

    Args:
        n_cand: N_cand, the candidate pool size (raised to the budget when the
            budget is larger, so the pool can fill it).
        alpha: weight of inconsistency (0.5 in the paper).
        eps: the min-max normalisation's epsilon.
        max_iter: k-means iterations at most.
        max_cand_fraction: the largest share of the unlabeled pool N_cand may be
            (``MAX_CAND_FRACTION``, a half): a larger N_cand raises
            ``CandidatePoolTooLarge`` at the query; None lifts the limit (a pool of
            n <= N_cand groups is then ranked whole).
    """

    name = "duis"
    needs = frozenset({"group_features", "margin_inconsistency"})

    def __init__(
        self,
        n_cand: int = 500,
        alpha: float = 0.5,
        eps: float = 1e-8,
        max_iter: int = 100,
        max_cand_fraction: float | None = MAX_CAND_FRACTION,
    ):
        if isinstance(n_cand, bool) or not isinstance(n_cand, int | np.integer) or n_cand < 1:
            raise ValueError(f"n_cand must be an integer >= 1, got {n_cand!r}.")
        if not 0.0 <= alpha <= 1.0:
            raise ValueError(f"alpha must be in [0, 1], got {alpha!r}.")
        if not eps > 0:
            raise ValueError(f"eps must be > 0, got {eps!r}.")
        if int(max_iter) < 1:
            raise ValueError(f"max_iter must be >= 1, got {max_iter!r}.")
        if max_cand_fraction is not None and not 0.0 < max_cand_fraction <= 1.0:
            raise ValueError(
                f"max_cand_fraction must be in (0, 1] or None, got {max_cand_fraction!r}."
            )
        self.n_cand, self.alpha, self.eps, self.max_iter = (
            int(n_cand),
            float(alpha),
            float(eps),
            int(max_iter),
        )
        self.max_cand_fraction = None if max_cand_fraction is None else float(max_cand_fraction)

    def params(self) -> dict:
        """The strategy's parameters, as recorded with its results."""
        return {"n_cand": self.n_cand, "alpha": self.alpha, "eps": self.eps}

    def check_pool(self, n_unlabeled: int) -> None:
        """Raise ``CandidatePoolTooLarge`` when N_cand is more than ``max_cand_fraction``
        of ``n_unlabeled`` groups (an empty pool, which makes no query, passes)."""
        if self.max_cand_fraction is None or n_unlabeled == 0:
            return
        message = n_cand_error(self.n_cand, n_unlabeled, fraction=self.max_cand_fraction)
        if message:
            raise CandidatePoolTooLarge(message, self.n_cand, n_unlabeled)

    def candidates(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        """Positions of the candidate pool C for a budget of ``k``."""
        self.check_pool(inputs.n_unlabeled)
        return candidate_pool(inputs.group_features, max(self.n_cand, k), rng, self.max_iter)

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        pool = self.candidates(inputs, k, rng)
        score = uis(inputs.gamma[pool], inputs.inconsistency[pool], self.alpha, self.eps)
        return pool[top_k(score, k, rng)]


def check_candidate_pool(strategy, n_unlabeled: int, **where) -> None:
    """A k-means candidate pool strategy's ``check_pool`` for a query of ``n_unlabeled``
    groups, its ``CandidatePoolTooLarge`` worded by ``n_cand_error`` with ``where``
    (round_, dataset, method, seed): the one sentence that names the run. Strategies
    without N_cand pass."""
    if getattr(strategy, "n_cand", None) is None:
        return
    try:
        strategy.check_pool(int(n_unlabeled))
    except CandidatePoolTooLarge as err:
        message = n_cand_error(
            err.n_cand, err.n_unlabeled, fraction=strategy.max_cand_fraction, **where
        )
        raise CandidatePoolTooLarge(message, err.n_cand, err.n_unlabeled) from None

"""k-means in float32 numpy: greedy k-means++ seeding, then Lloyd iterations.

Used by DUIS for its candidate pool. Written here rather than taken from
scikit-learn because sklearn's seeding upcasts float32 distances to float64 chunk
by chunk, which made a 20,000 x 512 pool with 500 clusters take ~8 s to seed on
two cores (this takes ~2 s), and because a selection step then imports numpy only.
Memory stays O((n + k) d + chunk), never n x k at once for large pools. Both
centre the points first (``spl_al.strategies.distances``): the distances cancel on
features with a common offset otherwise.
"""

from __future__ import annotations

import numpy as np

from spl_al.strategies.distances import centred, row_mean, sq_distances
from spl_al.strategies.units import check_points

# elements of one (points x centres) distance block (float32: 16 MB)
_CHUNK_ELEMENTS = 1 << 22


def assign(x: np.ndarray, x_sq: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest centre of every point and its squared distance, in row chunks.

    Args:
        x: (n, d) float32 points and centres: (k, d), both centred by the same mean
            (``sq_distances``); x_sq: (n,) squared row norms of x.

    Returns:
        labels (n,) int64 and squared distances (n,) float32.
    """
    n = len(x)
    labels = np.empty(n, dtype=np.int64)
    best = np.empty(n, dtype=np.float32)
    rows = max(1, _CHUNK_ELEMENTS // max(len(centres), 1))
    for s in range(0, n, rows):
        d2 = sq_distances(x[s : s + rows], x_sq[s : s + rows], centres)
        labels[s : s + rows] = d2.argmin(axis=1)
        best[s : s + rows] = np.take_along_axis(d2, labels[s : s + rows, None], axis=1)[:, 0]
    return labels, best


def _plusplus_rows(x: np.ndarray, x_sq: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """Rows of the centred (n, d) ``x`` that greedy k-means++ picks: (k,) int64."""
    n = len(x)
    trials = 2 + int(np.log(k))
    rows = np.empty(k, dtype=np.int64)
    rows[0] = first = rng.integers(n)
    closest = sq_distances(x, x_sq, x[first : first + 1])[:, 0]
    for c in range(1, k):
        cum = np.cumsum(closest, dtype=np.float64)
        if cum[-1] > 0:
            cand = np.minimum(
                np.searchsorted(cum, rng.random(trials) * cum[-1], side="right"), n - 1
            )
        else:  # every point sits on a centre: any choice is as good
            cand = rng.integers(n, size=trials)
        new_closest = np.minimum(closest[None], sq_distances(x, x_sq, x[cand], x_sq[cand]).T)
        best = int(np.argmin(new_closest.sum(axis=1, dtype=np.float64)))
        closest = new_closest[best]
        rows[c] = cand[best]
    return rows


def kmeans_plusplus(x, k: int, rng: np.random.Generator) -> np.ndarray:
    """Greedy k-means++ seeding (Arthur & Vassilvitskii 2007, with 2 + ln k local trials).

    The first centre is uniform; each next one is the best (lowest total potential)
    of 2 + ln k candidates drawn with probability proportional to D^2, the squared
    distance to the nearest chosen centre, computed on the centred points.

    Args:
        x: (n, d) points; k: number of centres, in [1, n].

    Returns:
        (k, d) float32 centres, rows of ``x``.
    """
    x = check_points(x)
    xc = centred(x, row_mean(x))
    return x[_plusplus_rows(xc, np.einsum("ij,ij->i", xc, xc), k, rng)]


def kmeans(
    x, k: int, *, rng: np.random.Generator, max_iter: int = 100, tol: float = 1e-4
) -> np.ndarray:
    """Lloyd's k-means from a k-means++ seeding, on the points less their mean.

    Stops when the total squared centre shift falls below ``tol`` times the mean
    per-feature variance (scikit-learn's rule) or after ``max_iter`` iterations. An
    empty cluster is re-seeded at the point farthest from its current centre.

    Args:
        x: (n, d) points; k: number of clusters, in [1, n].

    Returns:
        (k, d) float64 centres in the coordinates of ``x``: float32 would round them to
        the scale of the features' offset, enough to change which point is nearest.
    """
    x = check_points(x)
    n = len(x)
    if not 1 <= k <= n:
        raise ValueError(f"k must be in [1, {n}] clusters, got {k}.")
    mean = row_mean(x)
    x = centred(x, mean)
    x_sq = np.einsum("ij,ij->i", x, x)
    centres = x[_plusplus_rows(x, x_sq, k, rng)]
    tol_abs = tol * float(np.mean(np.var(x, axis=0, dtype=np.float64)))
    for _ in range(max_iter):
        labels, d2 = assign(x, x_sq, centres)
        counts = np.bincount(labels, minlength=k)
        order = np.argsort(labels, kind="stable")
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        sums = np.zeros_like(centres, dtype=np.float64)
        filled = counts > 0
        sums[filled] = np.add.reduceat(x[order], starts[filled], axis=0, dtype=np.float64)
        new = np.where(filled[:, None], sums / np.maximum(counts, 1)[:, None], centres)
        if not filled.all():  # re-seed empty clusters at the worst-served points
            far = np.argsort(-d2, kind="stable")[: int((~filled).sum())]
            new[~filled] = x[far]
        new = new.astype(np.float32)
        shift = float(np.sum((new - centres).astype(np.float64) ** 2))
        centres = new
        if shift <= tol_abs:
            break
    return centres + mean


def unit_clusters(x: np.ndarray, k: int, *, rng: np.random.Generator) -> np.ndarray:
    """Cluster of every row of the unit-length (n, d) float32 ``x`` after ``kmeans`` into
    ``k``: (n,) int64. The points sit on the unit sphere (no offset to cancel), so the
    nearest centre is found on the points less their float32 mean (TypiClust's and
    ProbCover's clusters)."""
    centres = kmeans(x, k, rng=rng).astype(np.float32)
    mean = x.mean(axis=0)
    xc = x - mean
    labels, _ = assign(xc, np.einsum("ij,ij->i", xc, xc), centres - mean)
    return labels

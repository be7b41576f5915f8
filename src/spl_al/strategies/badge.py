"""BADGE (Ash et al. 2020): k-means++ seeding on last-layer gradient embeddings.

The gradient of the cross-entropy under the predicted (argmax) label with respect
to the last layer's weights is g = (p - onehot(argmax p)) ⊗ h, with h the
penultimate features: a rank-one C x d matrix. Squared distances between such
embeddings factorise,

    <g_i, g_j> = <q_i, q_j> <h_i, h_j>,   q = p - onehot,

so k-means++ needs O(n (C + d)) per pick instead of materialising n x C*d. For
segmentation the embedding is averaged over an image's valid pixels,
G = mean_u q_u h_u^T, which is no longer rank one and is kept dense (C * d small).
"""

from __future__ import annotations

import numpy as np

from spl_al.strategies.base import Strategy, register
from spl_al.strategies.distances import centred, row_mean
from spl_al.strategies.inputs import StrategyInputs
from spl_al.strategies.units import check_probs

FIRST_CENTRE = ("max_norm", "random")


def _residual(p: np.ndarray) -> np.ndarray:
    """q = p - onehot(argmax p) along the last axis."""
    q = p.copy()
    top = p.argmax(axis=-1)[..., None]
    np.put_along_axis(q, top, np.take_along_axis(p, top, axis=-1) - 1.0, axis=-1)
    return q


def gradient_embedding_factors(probs, features) -> tuple[np.ndarray, np.ndarray]:
    """Rank-one factors of the classification gradient embedding.

    Args:
        probs: (n, C) class probabilities; features: (n, d) penultimate features.

    Returns:
        q = p - onehot(argmax p), (n, C) float32, and h = features, (n, d) float32.
    """
    p = check_probs(probs, 2)
    h = np.asarray(features, dtype=np.float32)
    if h.ndim != 2 or len(h) != len(p):
        raise ValueError(f"features must be (n, d) with n = {len(p)}, got {h.shape}.")
    return _residual(p).astype(np.float32), h


def pixel_gradient_embedding(probs, features, valid=None) -> np.ndarray:
    """Pixel-averaged gradient embedding for segmentation, flattened: (groups, C * d).

    G_i = mean over valid units u of (p_u - onehot(argmax p_u)) h_u^T.

    Args:
        probs: (groups, units, C); features: (groups, units, d); valid: (groups, units) or None.
        A group without valid units averages over all of its units.
    """
    p = check_probs(probs, 3)
    h = np.asarray(features, dtype=np.float64)
    if h.ndim != 3 or h.shape[:2] != p.shape[:2]:
        raise ValueError(
            f"features must be (groups, units, d) matching probs {p.shape[:2]}, got {h.shape}."
        )
    w = np.ones(p.shape[:2]) if valid is None else np.asarray(valid, dtype=np.float64)
    if w.shape != p.shape[:2]:
        raise ValueError(f"valid must have shape {p.shape[:2]}, got {w.shape}.")
    w = np.where(w.sum(1, keepdims=True) > 0, w, 1.0)
    w = w / w.sum(1, keepdims=True)
    emb = np.einsum("guc,gud,gu->gcd", _residual(p), h, w)
    return emb.reshape(len(p), -1).astype(np.float32)


class _GradientPoints:
    """Squared distances between gradient embeddings, from rank-one factors or dense vectors.

    Dense (n, D) embeddings e: ||e_i - e_j||^2 = |e_i|^2 + |e_j|^2 - 2 e_i . e_j on
    e - mean(e) (``spl_al.strategies.distances``). Rank-one factors q (n, C), h (n, d):

        ||g_i - g_j||^2 = |q_i|^2 |h_i|^2 + |q_j|^2 |h_j|^2 - 2 (q_i . q_j)(h_i . h_j),
        h_i . h_j = |c|^2 + r_i . c + r_j . c + r_i . r_j,   c = mean(h), r = h - c,

    with |h_i|^2 = h_i . h_i from the same terms. The products r_i . r_j and r_i . c
    of centred features are float32; the sums are float64, whose 16 digits hold what
    they cancel when the features share an offset c (float32's 7 do not).
    """

    def __init__(self, q=None, h=None, dense=None) -> None:
        if dense is not None:
            e = np.asarray(dense, dtype=np.float32)
            self.norm_sq = np.einsum("ij,ij->i", e, e, dtype=np.float64)  # the first centre
            self.e = centred(e, row_mean(e))
            self.sq = np.einsum("ij,ij->i", self.e, self.e, dtype=np.float64)
            self.q = self.r = None
        else:
            self.q = np.asarray(q, dtype=np.float64)
            h = np.asarray(h, dtype=np.float32)
            if self.q.ndim != 2 or h.ndim != 2 or len(self.q) != len(h):
                raise ValueError(
                    f"grad_q and grad_h must be (n, C) and (n, d), got {self.q.shape}, {h.shape}."
                )
            c = row_mean(h)
            self.r = centred(h, c)
            self.c_sq = float(c @ c)
            self.r_c = (self.r @ c.astype(np.float32)).astype(np.float64)
            h_sq = np.einsum("ij,ij->i", self.r, self.r, dtype=np.float64)
            h_sq += 2.0 * self.r_c + self.c_sq
            self.norm_sq = self.sq = np.einsum("ij,ij->i", self.q, self.q) * h_sq
            self.e = None
        self.n = len(self.sq)

    def sq_dist_to(self, j: int) -> np.ndarray:
        if self.e is not None:
            dot = (self.e @ self.e[j]).astype(np.float64)
        else:
            h_dot = (self.r @ self.r[j]).astype(np.float64)
            h_dot += self.r_c + (self.r_c[j] + self.c_sq)
            dot = (self.q @ self.q[j]) * h_dot
        return np.maximum(self.sq + self.sq[j] - 2.0 * dot, 0.0)


def kmeans_pp_seeding(
    k: int,
    rng: np.random.Generator,
    *,
    q=None,
    h=None,
    gradients=None,
    first: str = "max_norm",
) -> np.ndarray:
    """k-means++ seeding (D^2 sampling) over gradient embeddings; k distinct positions.

    The first centre is the embedding of largest norm (``first="max_norm"``, as in the
    BADGE reference code) or uniform (``"random"``); each next centre is drawn with
    probability proportional to its squared distance to the nearest chosen centre.
    Chosen points have weight 0, so nothing repeats; when every remaining point
    coincides with a centre (all weights 0) the next pick is uniform among them.

    Args:
        k: number of centres (<= n).
        q, h: rank-one factors (n, C), (n, d); or ``gradients`` (n, D) dense.
    """
    if first not in FIRST_CENTRE:
        raise ValueError(f"first must be one of {FIRST_CENTRE}, got {first!r}.")
    emb = _GradientPoints(dense=gradients) if gradients is not None else _GradientPoints(q, h)
    n = emb.n
    if not 0 <= k <= n:
        raise ValueError(f"k must be in [0, {n}], got {k}.")
    chosen = np.zeros(n, dtype=bool)
    picks = np.empty(k, dtype=np.int64)
    min_d2 = np.full(n, np.inf)
    for t in range(k):
        if t == 0:
            if first == "random":
                pick = rng.integers(n)
            else:
                best = np.flatnonzero(emb.norm_sq == emb.norm_sq.max())
                pick = best[0] if len(best) == 1 else rng.choice(best)
        else:
            weight = np.where(chosen, 0.0, min_d2)
            cum = np.cumsum(weight)
            total = cum[-1]
            if total > 0 and np.isfinite(total):
                pick = int(np.searchsorted(cum, rng.random() * total, side="right"))
                pick = min(pick, n - 1)
                if chosen[pick]:  # only reachable through rounding at the very end
                    pick = int(np.flatnonzero(~chosen & (weight > 0))[-1])
            else:
                pick = rng.choice(np.flatnonzero(~chosen))
        picks[t] = pick
        chosen[pick] = True
        min_d2 = np.minimum(min_d2, emb.sq_dist_to(pick))
    return picks


@register
class BadgeStrategy(Strategy):
    """BADGE: k-means++ seeding on the observed images' gradient embeddings.

    Args:
        first: first centre, "max_norm" (reference implementation) or "random".
    """

    name = "badge"
    needs = frozenset({"grad_embedding"})

    def __init__(self, first: str = "max_norm") -> None:
        if first not in FIRST_CENTRE:
            raise ValueError(f"first must be one of {FIRST_CENTRE}, got {first!r}.")
        self.first = first

    def params(self) -> dict:
        """The strategy's parameters, as recorded with its results."""
        return {"first": self.first}

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        if inputs.grad_embedding is not None:
            return kmeans_pp_seeding(k, rng, gradients=inputs.grad_embedding, first=self.first)
        return kmeans_pp_seeding(k, rng, q=inputs.grad_q, h=inputs.grad_h, first=self.first)

"""Distance-based strategies under a common offset of the features.

Core-set, k-means (DUIS's candidate pool) and BADGE's k-means++ compute squared
distances as |x|^2 - 2 x.c + |c|^2; on features sharing a large offset that form
cancels catastrophically in float32 unless the features are centred first. Every
shift here is exact in float32 (the features are multiples of 2^-8 below 8 in
magnitude, so x + 1000 is representable), so any change of picks is the algorithm's.
"""

import numpy as np

from spl_al.strategies.badge import gradient_embedding_factors, kmeans_pp_seeding
from spl_al.strategies.coreset import k_center_greedy
from spl_al.strategies.distances import centred, row_mean
from spl_al.strategies.duis import candidate_pool
from spl_al.strategies.kmeans import kmeans, kmeans_plusplus

OFFSET = 1e3


def _features(n: int, d: int, seed: int) -> np.ndarray:
    """(n, d) float32 features like a penultimate layer's, exactly shiftable by OFFSET."""
    x = np.random.default_rng(seed).normal(size=(n, d)).clip(-7.9, 7.9)
    x = (np.round(x * 256) / 256).astype(np.float32)
    assert np.array_equal((x + np.float32(OFFSET)) - np.float32(OFFSET), x)
    return x


def _nearest(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Nearest centre of every point, from float64 differences (no cancellation)."""
    diff = points.astype(np.float64)[:, None] - centres.astype(np.float64)[None]
    return np.einsum("ijk,ijk->ij", diff, diff).argmin(axis=1)


def test_centring_leaves_no_trace_of_an_exact_offset():
    x = _features(500, 64, 7)
    a = centred(x, row_mean(x[:100], x[100:]))
    assert a.dtype == np.float32 and a.flags.c_contiguous
    assert np.allclose(a.mean(axis=0, dtype=np.float64), 0.0, atol=1e-6)
    assert np.array_equal(centred(x + OFFSET, row_mean(x + OFFSET)), a)


def test_coreset_picks_ignore_a_common_offset():
    x, labeled = _features(2000, 64, 0), _features(300, 64, 1)
    picks = k_center_greedy(x, labeled, 100, np.random.default_rng(0))
    shifted = k_center_greedy(x + OFFSET, labeled + OFFSET, 100, np.random.default_rng(0))
    assert shifted.tolist() == picks.tolist()


def test_kmeans_clustering_ignores_a_common_offset():
    x = _features(2000, 64, 2)
    seeds = kmeans_plusplus(x, 50, np.random.default_rng(0))
    seeds_shifted = kmeans_plusplus(x + OFFSET, 50, np.random.default_rng(0))
    assert np.array_equal(seeds_shifted, seeds + np.float32(OFFSET))  # the same rows

    centres = kmeans(x, 50, rng=np.random.default_rng(0))
    centres_shifted = kmeans(x + OFFSET, 50, rng=np.random.default_rng(0))
    assert np.allclose(centres_shifted - OFFSET, centres, rtol=0, atol=1e-9)
    labels = _nearest(x, centres)
    assert np.array_equal(_nearest(x + OFFSET, centres_shifted), labels)
    assert len(np.unique(labels)) == 50


def test_duis_candidate_pool_ignores_a_common_offset():
    x = _features(2000, 64, 3)
    pool = candidate_pool(x, 200, np.random.default_rng(0))
    shifted = candidate_pool(x + OFFSET, 200, np.random.default_rng(0))
    assert shifted.tolist() == pool.tolist()


def test_badge_picks_ignore_a_common_offset_of_dense_embeddings():
    # "max_norm" starts at the largest norm, which an offset changes; "random" does not
    emb = _features(2000, 11 * 16, 4)  # a segmentation pool's (groups, C * d) embeddings
    picks = kmeans_pp_seeding(100, np.random.default_rng(0), gradients=emb, first="random")
    shifted = kmeans_pp_seeding(
        100, np.random.default_rng(0), gradients=emb + OFFSET, first="random"
    )
    assert shifted.tolist() == picks.tolist()


def _kmeans_pp_reference(emb: np.ndarray, k: int, rng: np.random.Generator) -> list[int]:
    """BADGE's seeding (first at the largest norm) with float64 differences for D^2."""
    e = emb.astype(np.float64)
    chosen = np.zeros(len(e), dtype=bool)
    min_d2 = np.full(len(e), np.inf)
    picks = []
    for t in range(k):
        if t == 0:
            pick = int(np.argmax(np.einsum("ij,ij->i", e, e)))
        else:
            cum = np.cumsum(np.where(chosen, 0.0, min_d2))
            pick = int(np.searchsorted(cum, rng.random() * cum[-1], side="right"))
        picks.append(pick)
        chosen[pick] = True
        diff = e - e[pick]
        min_d2 = np.minimum(min_d2, np.einsum("ij,ij->i", diff, diff))
    return picks


def test_badge_factorised_picks_are_exact_on_offset_features():
    # ReLU features share a large positive offset. Where two images' residuals q agree
    # (here: 20 predictions, each shared by 100 images), their distance is |q|^2 times
    # that of their features alone, which the uncentred rank-one form cancels away.
    rng = np.random.default_rng(5)
    logits = rng.normal(0, 2, (20, 11))[rng.integers(0, 20, 2000)]
    probs = np.exp(logits) / np.exp(logits).sum(axis=1, keepdims=True)
    q, h = gradient_embedding_factors(probs, _features(2000, 64, 6) + OFFSET)
    dense = (q.astype(np.float64)[:, :, None] * h[:, None, :]).reshape(len(q), -1)
    picks = kmeans_pp_seeding(100, np.random.default_rng(0), q=q, h=h)
    assert picks.tolist() == _kmeans_pp_reference(dense, 100, np.random.default_rng(0))

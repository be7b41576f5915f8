"""Acquisition strategies: hand-computed scores, algorithms, and one shared contract."""

import inspect
import subprocess
import sys

import numpy as np
import pytest

from spl_al import strategies
from spl_al.strategies import NEEDS, StrategyInputs
from spl_al.strategies.badge import (
    gradient_embedding_factors,
    kmeans_pp_seeding,
    pixel_gradient_embedding,
)
from spl_al.strategies.coreset import k_center_greedy
from spl_al.strategies.duis import (
    CandidatePoolTooLarge,
    candidate_pool,
    margin_and_inconsistency,
    nearest_unique,
    uis,
)
from spl_al.strategies.entropy import entropy_score
from spl_al.strategies.kmeans import kmeans
from spl_al.strategies.margin import margin_score
from spl_al.strategies.units import top_k

LN2 = np.log(2.0)


# ---------------------------------------------------------------- hand-computed scores


def test_entropy_and_margin_by_hand():
    probs = np.array([[[0.5, 0.5, 0.0]], [[1.0, 0.0, 0.0]], [[0.7, 0.2, 0.1]]])
    expected_h = [LN2, 0.0, -(0.7 * np.log(0.7) + 0.2 * np.log(0.2) + 0.1 * np.log(0.1))]
    assert entropy_score(probs) == pytest.approx(expected_h)
    assert margin_score(probs) == pytest.approx([0.0, 1.0, 0.5])


def test_margin_and_kl_to_mean_by_hand():
    # one group, M + 1 = 2 images, one unit: q1 = (1, 0), q2 = (0.5, 0.5)
    probs = np.array([[[[1.0, 0.0]], [[0.5, 0.5]]]])
    gamma, d = margin_and_inconsistency(probs)
    # qbar = (0.75, 0.25): gamma = 0.5
    # KL(q1||qbar) = ln(1 / 0.75); KL(q2||qbar) = 0.5 ln(0.5 / 0.75) + 0.5 ln(0.5 / 0.25)
    kl1 = np.log(1 / 0.75)
    kl2 = 0.5 * np.log(0.5 / 0.75) + 0.5 * np.log(2.0)
    assert gamma == pytest.approx([0.5])
    assert d == pytest.approx([(kl1 + kl2) / 2])
    assert d[0] == pytest.approx(0.2157615543388357)
    # identical predictions: no inconsistency; a one-hot everywhere: margin 1
    same = np.tile(np.array([0.2, 0.3, 0.5]), (1, 4, 1, 1))
    assert margin_and_inconsistency(same)[1] == pytest.approx([0.0], abs=1e-15)
    onehot = np.tile(np.array([0.0, 1.0, 0.0]), (2, 3, 5, 1))
    g, dd = margin_and_inconsistency(onehot)
    assert g.tolist() == [1.0, 1.0] and dd.tolist() == [0.0, 0.0]


def test_segmentation_kl_skips_void_pixels_of_each_image_by_hand():
    """One group, observed image + 1 variant, 2 pixels. Pixel 0 is valid in both;
    pixel 1 is a void in the variant, so it carries no prediction there: qbar at
    pixel 1 is the observed prediction alone and the variant's KL averages over
    pixel 0 only, while the margin averages over both observed-valid pixels."""
    q_obs = [[1.0, 0.0], [0.6, 0.4]]
    q_var = [[0.5, 0.5], [0.0, 1.0]]  # its pixel-1 prediction must not count
    probs = np.array([[q_obs, q_var]])  # (1, 2, 2, 2)
    images = np.array([[[True, True], [True, False]]])
    gamma, d = margin_and_inconsistency(probs, image_valid=images)
    # pixel 0: qbar = (0.75, 0.25), gap 0.5; pixel 1: qbar = (0.6, 0.4), gap 0.2
    assert gamma == pytest.approx([(0.5 + 0.2) / 2])
    kl_obs_0 = np.log(1 / 0.75)  # pixel 1 of the observed image: KL(q || q) = 0
    kl_var_0 = 0.5 * np.log(0.5 / 0.75) + 0.5 * np.log(0.5 / 0.25)
    assert d == pytest.approx([((kl_obs_0 + 0.0) / 2 + kl_var_0) / 2])
    # the observed mask restricts every term; a group without valid units is NaN
    g_only0, d_only0 = margin_and_inconsistency(
        probs, valid=np.array([[True, False]]), image_valid=images
    )
    assert g_only0 == pytest.approx([0.5]) and d_only0 == pytest.approx([(kl_obs_0 + kl_var_0) / 2])
    empty = margin_and_inconsistency(probs, image_valid=np.zeros((1, 2, 2), bool))
    assert np.isnan(empty[0]).all() and np.isnan(empty[1]).all()
    with pytest.raises(ValueError, match="image_valid must have shape"):
        margin_and_inconsistency(probs, image_valid=images[:, :1])


def test_uis_by_hand():
    gamma = np.array([0.1, 0.5, 0.3])
    d = np.array([0.2, 0.0, 0.4])
    # d~ = (0.5, 0, 1), gamma~ = (0, 1, 0.5) -> UIS_0.5 = (0.75, 0, 0.75)
    assert uis(gamma, d, 0.5, 1e-12) == pytest.approx([0.75, 0.0, 0.75], abs=1e-9)
    assert uis(gamma, d, 1.0, 1e-12) == pytest.approx([0.5, 0.0, 1.0], abs=1e-9)
    assert uis(gamma, d, 0.0, 1e-12) == pytest.approx([1.0, 0.0, 0.5], abs=1e-9)
    # epsilon in the denominator: values differ by 1, eps = 1 halves the spread
    assert uis(np.array([0.0, 1.0]), np.array([0.0, 1.0]), 0.5, 1.0) == pytest.approx([0.5, 0.5])
    # all equal: both normalised terms are 0, UIS = 1 - alpha everywhere, no NaN
    assert uis(np.full(4, 0.3), np.full(4, 0.1), 0.25) == pytest.approx([0.75] * 4)
    for bad in ({"alpha": 1.5}, {"eps": 0.0}):
        with pytest.raises(ValueError):
            uis(gamma, d, **{"alpha": 0.5, "eps": 1e-8, **bad})


def test_segmentation_scores_average_over_valid_pixels_only():
    rng = np.random.default_rng(0)
    probs = rng.dirichlet(np.ones(4), size=(3, 5, 6))  # (groups, M+1, units, C)
    valid = rng.random((3, 6)) < 0.6
    valid[:, 0] = True
    garbage = probs.copy()
    garbage[:, :, ~valid[0]] = rng.dirichlet(np.ones(4), size=(3, 5, (~valid[0]).sum()))
    for g in range(3):  # reference: each group's valid units alone
        keep = valid[g]
        h = entropy_score(probs[g : g + 1, 0, keep])
        m = margin_score(probs[g : g + 1, 0, keep])
        gm, dm = margin_and_inconsistency(probs[g : g + 1, :, keep])
        assert entropy_score(probs[:, 0], valid)[g] == pytest.approx(h[0])
        assert margin_score(probs[:, 0], valid)[g] == pytest.approx(m[0])
        got = margin_and_inconsistency(probs, valid)
        assert (got[0][g], got[1][g]) == pytest.approx((gm[0], dm[0]))
    # what sits at invalid pixels changes nothing (group 0's invalid pixels were redrawn)
    assert np.allclose(
        margin_and_inconsistency(garbage, valid), margin_and_inconsistency(probs, valid)
    )
    no_units = np.zeros((3, 6), bool)
    assert np.isnan(entropy_score(probs[:, 0], no_units)).all()


def test_top_k_breaks_ties_with_the_rng_and_ranks_nan_last():
    s = np.array([1.0, np.nan, 3.0, 3.0, 0.5])
    firsts = {tuple(top_k(s, 2, np.random.default_rng(seed))) for seed in range(20)}
    assert firsts == {(2, 3), (3, 2)}
    assert top_k(s, 5, np.random.default_rng(0))[-1] == 1
    assert len(top_k(s, 99, np.random.default_rng(0))) == 5


# ---------------------------------------------------------------- coreset


def test_coreset_picks_the_farthest_point_on_a_line():
    x = np.array([[1.0], [2.0], [10.0], [5.0], [0.5]])
    labeled = np.array([[0.0]])
    picks = k_center_greedy(x, labeled, 3, np.random.default_rng(0))
    # from {0}: 10 is farthest; from {0, 10}: 5 (distance 5); then 2 (distance 2)
    assert picks.tolist() == [2, 3, 1]


def _brute_force_k_center(x, labeled, k):
    allx = np.concatenate([labeled, x])
    dist = np.linalg.norm(allx[:, None] - allx[None], axis=-1)  # full matrix, as references do
    centres = list(range(len(labeled)))
    picks = []
    for _ in range(k):
        min_d = dist[:, centres].min(axis=1)[len(labeled) :]
        min_d[picks] = -1
        j = int(np.argmax(min_d))
        picks.append(j)
        centres.append(j + len(labeled))
    return picks


def test_coreset_matches_the_full_distance_matrix_version():
    rng = np.random.default_rng(1)
    x, labeled = rng.normal(size=(200, 8)), rng.normal(size=(7, 8))
    ours = k_center_greedy(x, labeled, 15, np.random.default_rng(0))
    assert ours.tolist() == _brute_force_k_center(x, labeled, 15)


def test_coreset_without_labeled_set_and_with_duplicates():
    x = np.zeros((6, 3))
    picks = k_center_greedy(x, np.zeros((0, 3)), 6, np.random.default_rng(0))
    assert sorted(picks.tolist()) == list(range(6))


# ---------------------------------------------------------------- badge


def _badge_inputs(n=60, c=4, d=5, seed=0):
    rng = np.random.default_rng(seed)
    return gradient_embedding_factors(rng.dirichlet(np.ones(c), n), rng.normal(size=(n, d)))


def test_gradient_embedding_is_p_minus_onehot_times_features():
    q, h = gradient_embedding_factors(np.array([[0.2, 0.7, 0.1]]), np.array([[1.0, 2.0]]))
    assert np.allclose(q, [[0.2, -0.3, 0.1]]) and h.tolist() == [[1.0, 2.0]]
    seg = pixel_gradient_embedding(
        np.array([[[0.2, 0.8], [0.6, 0.4], [0.5, 0.5]]]),
        np.array([[[1.0], [3.0], [100.0]]]),
        np.array([[True, True, False]]),
    )
    # mean over the two valid pixels of q_u * h_u: ((0.2, -0.2) * 1 + (-0.4, 0.4) * 3) / 2
    assert np.allclose(seg, [[-0.5, 0.5]])


def test_badge_is_deterministic_never_repeats_and_starts_at_max_norm():
    q, h = _badge_inputs()
    a = kmeans_pp_seeding(20, np.random.default_rng(5), q=q, h=h)
    b = kmeans_pp_seeding(20, np.random.default_rng(5), q=q, h=h)
    c = kmeans_pp_seeding(20, np.random.default_rng(6), q=q, h=h)
    assert a.tolist() == b.tolist() and a.tolist() != c.tolist()
    assert len(set(a.tolist())) == 20
    norms = np.linalg.norm(q, axis=1) * np.linalg.norm(h, axis=1)
    assert a[0] == np.argmax(norms)
    # every point, with exact duplicates in the pool: still no repeats
    qq, hh = np.concatenate([q, q]), np.concatenate([h, h])
    all_picks = kmeans_pp_seeding(120, np.random.default_rng(0), q=qq, h=hh)
    assert sorted(all_picks.tolist()) == list(range(120))


def test_badge_factorised_distances_equal_dense_embeddings():
    q, h = _badge_inputs()
    dense = (q[:, :, None] * h[:, None, :]).reshape(len(q), -1)
    fact = kmeans_pp_seeding(25, np.random.default_rng(3), q=q, h=h)
    full = kmeans_pp_seeding(25, np.random.default_rng(3), gradients=dense)
    assert fact.tolist() == full.tolist()


def test_badge_spreads_over_far_apart_clusters():
    rng = np.random.default_rng(0)
    centres = np.array([[0.0, 0.0], [1000.0, 0.0], [0.0, 1000.0]])
    emb = np.concatenate([c + rng.normal(0, 0.01, (30, 2)) for c in centres])
    picks = kmeans_pp_seeding(3, np.random.default_rng(1), gradients=emb, first="random")
    assert sorted(p // 30 for p in picks) == [0, 1, 2]


# ---------------------------------------------------------------- duis


def test_kmeans_recovers_separated_blobs():
    rng = np.random.default_rng(0)
    means = np.array([[0, 0], [10, 0], [0, 10], [10, 10]], float)
    x = np.concatenate([m + rng.normal(0, 0.2, (40, 2)) for m in means])
    centres = kmeans(x, 4, rng=np.random.default_rng(1))
    got = centres[np.lexsort(np.round(centres).T[::-1])]
    assert np.allclose(got, means[np.lexsort(means.T[::-1])], atol=0.15)


def test_candidate_pool_has_n_cand_unique_members():
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.normal(size=(50, 4)), np.zeros((100, 4))])  # many duplicates
    for n_cand in (1, 10, 60, 149):
        pool = candidate_pool(x, n_cand, np.random.default_rng(2))
        assert len(pool) == n_cand == len(np.unique(pool))
        assert pool.min() >= 0 and pool.max() < len(x)
    assert candidate_pool(x, 500, np.random.default_rng(0)).tolist() == list(range(150))
    # two centres whose nearest point is the same get distinct points
    pts = np.array([[0.0], [1.0], [5.0]])
    assert sorted(nearest_unique(pts, np.array([[0.1], [0.2]])).tolist()) == [0, 1]


def test_duis_ranks_the_candidate_pool_by_uis():
    inputs = make_inputs(n_unl=25)
    ref = uis(inputs.gamma, inputs.inconsistency, 0.3, 1e-8)
    whole = {"n_cand": 100, "max_cand_fraction": None}  # the limit lifted: the whole pool
    picks = strategies.get("duis", alpha=0.3, **whole).select(inputs, 6, np.random.default_rng(0))
    expected = inputs.unlabeled_idx[np.argsort(-ref, kind="stable")[:6]]
    assert picks.tolist() == expected.tolist()
    div = strategies.get("diversity", **whole).select(inputs, 6, np.random.default_rng(0))
    assert div.tolist() == inputs.unlabeled_idx[np.argsort(inputs.gamma)[:6]].tolist()


def test_duis_picks_only_from_its_candidate_pool():
    inputs = make_inputs(n_unl=80)
    duis = strategies.get("duis", n_cand=12)
    pool = duis.candidates(inputs, 5, np.random.default_rng(4))
    picks = duis.select(inputs, 5, np.random.default_rng(4))
    assert set(picks.tolist()) <= set(inputs.unlabeled_idx[pool].tolist())
    # a budget above N_cand widens the pool to the budget instead of failing
    assert len(np.unique(duis.select(inputs, 30, np.random.default_rng(4)))) == 30


@pytest.mark.parametrize("name", ["duis", "diversity"])
def test_n_cand_above_half_the_unlabeled_pool_is_one_sentence(name):
    inputs = make_inputs(n_unl=30)
    assert len(strategies.get(name, n_cand=15).select(inputs, 4, np.random.default_rng(0))) == 4
    with pytest.raises(CandidatePoolTooLarge) as err:
        strategies.get(name, n_cand=16).select(inputs, 4, np.random.default_rng(0))
    message = str(err.value)
    assert isinstance(err.value, ValueError)
    assert (err.value.n_cand, err.value.n_unlabeled) == (16, 30)
    assert "N_cand = 16 from 30 unlabeled groups (53%" in message
    assert message.endswith("set n_cand <= 15.") and message.count(". ") == 0
    lifted = strategies.get(name, n_cand=16, max_cand_fraction=None)
    assert len(lifted.select(inputs, 4, np.random.default_rng(0))) == 4
    with pytest.raises(ValueError, match="max_cand_fraction"):
        strategies.get(name, max_cand_fraction=0.0)


# ---------------------------------------------------------------- one contract for all


def make_inputs(n_unl=30, n_lab=6, c=4, d=5, g=3, kind="random", dense=False, seed=0):
    """Inputs for every need, computed with the library's own scoring functions."""
    rng = np.random.default_rng(seed)
    order = rng.permutation(n_unl + n_lab)
    if kind == "random":
        probs = rng.dirichlet(np.ones(c), size=(n_unl, g, 1))
        feats = rng.normal(size=(n_unl, g, d))
    elif kind == "identical":  # an untrained model: the same output for everything
        probs = np.broadcast_to(np.full(c, 1.0 / c), (n_unl, g, 1, c)).copy()
        feats = np.ones((n_unl, g, d))
    elif kind == "one_class":  # one class predicted everywhere, with certainty
        probs = np.zeros((n_unl, g, 1, c))
        probs[..., 0] = 1.0
        feats = rng.normal(size=(n_unl, g, d))
    gamma, incons = margin_and_inconsistency(probs)
    parts = {
        "entropy": entropy_score(probs[:, 0]),
        "margin": margin_score(probs[:, 0]),
        "gamma": gamma,
        "inconsistency": incons,
        "features": feats[:, 0],
        "group_features": feats.mean(axis=1),
        "labeled_features": rng.normal(size=(n_lab, d)),
        # a linear head: logits = features @ W.T + b (DropQuery's)
        "head_weight": rng.normal(size=(c, d)),
        "head_bias": rng.normal(size=c),
        "head_dropout": np.float64(0.5),
    }
    if dense:
        parts["grad_embedding"] = pixel_gradient_embedding(probs[:, 0], feats[:, 0][:, None])
    else:
        parts["grad_q"], parts["grad_h"] = gradient_embedding_factors(probs[:, 0, 0], feats[:, 0])
    return StrategyInputs(unlabeled_idx=np.sort(order[:n_unl]), labeled_idx=order[n_unl:], **parts)


# duis and diversity at their defaults (N_cand 500) only with the half-pool limit lifted;
# the generic scikit-activeml adapter with one class
DEFAULTS = {
    "duis": {"max_cand_fraction": None},
    "diversity": {"max_cand_fraction": None},
    "skactiveml": {"cls": "TypiClust"},
    "probcover": {"n_classes": 4},  # built without it, it refuses to select
}
BUILTIN = strategies.base.builtin_names()
# the scikit-activeml strategies need the optional extra spl-al[baselines]
SKACTIVEML = {"skactiveml", "maxherding"}
try:
    import skactiveml  # noqa: F401

    HAS_SKACTIVEML = True
except ImportError:
    HAS_SKACTIVEML = False


def _case(name, params):
    marks = []
    if name in SKACTIVEML and not HAS_SKACTIVEML:
        marks = [pytest.mark.skip(reason="scikit-activeml is not installed (spl-al[baselines])")]
    tag = "-".join(f"{k}{v}" for k, v in params.items())
    return pytest.param(name, params, marks=marks, id=f"{name}-{tag}")


CASES = [_case(name, DEFAULTS.get(name, {})) for name in BUILTIN] + [
    _case("duis", {"n_cand": 5}),
    _case("diversity", {"n_cand": 5}),
    _case("duis", {"n_cand": 8, "alpha": 1.0}),
    _case("badge", {"first": "random"}),
    _case("probcover", {"n_classes": 4, "purity": 0.5}),
    _case("typiclust", {"k_nn": 3, "min_cluster_size": 0}),
    _case("maxherding", {"bandwidth": 0.3}),
    _case("dropquery", {"passes": 5, "dropout": 0.5}),
    _case("skactiveml", {"cls": "MaxHerding", "metric": "linear"}),
]


def test_registry_lists_every_strategy_of_the_paper():
    assert set(BUILTIN) == {
        "random", "entropy", "margin", "coreset", "badge", "duis", "diversity",
        "skactiveml", "typiclust", "probcover", "maxherding", "dropquery",
    }  # fmt: skip
    for name in set(BUILTIN) - (set() if HAS_SKACTIVEML else SKACTIVEML):
        s = strategies.get(name, **DEFAULTS.get(name, {}))
        assert s.needs <= set(NEEDS) and s.name == name
    with pytest.raises(ValueError, match="unknown strategy"):
        strategies.get("bald")
    with pytest.raises(ValueError, match="parameters"):
        strategies.get("entropy", alpha=0.5)
    with pytest.raises(ValueError):
        strategies.get("duis", n_cand=0)


def check_contract(name, params, inputs):
    """The shared strategy contract on ``inputs``: for every budget, min(budget, n)
    distinct unlabeled picks, never a labeled one, the same under the same rng; the
    whole pool when the budget exceeds it."""
    strategy = strategies.get(name, **params)
    n = inputs.n_unlabeled
    for budget in (0, 1, 7, n - 1, n, n + 5):
        picks = strategy.select(inputs, budget, np.random.default_rng(11))
        assert picks.dtype == np.int64 and len(picks) == min(budget, n)
        assert len(np.unique(picks)) == len(picks), "duplicate picks"
        assert set(picks.tolist()) <= set(inputs.unlabeled_idx.tolist())
        assert not set(picks.tolist()) & set(inputs.labeled_idx.tolist())
        again = strategy.select(inputs, budget, np.random.default_rng(11))
        assert picks.tolist() == again.tolist(), "not reproducible under the same rng"
    assert sorted(strategy.select(inputs, n + 5, np.random.default_rng(0))) == sorted(
        inputs.unlabeled_idx
    )


@pytest.mark.parametrize(("name", "params"), CASES)
@pytest.mark.parametrize("kind", ["random", "identical", "one_class"])
@pytest.mark.parametrize("dense", [False, True], ids=["cls", "seg"])
def test_strategy_contract(name, params, kind, dense):
    check_contract(name, params, make_inputs(kind=kind, dense=dense))


@pytest.mark.parametrize(("name", "params"), CASES)
def test_strategy_contract_errors(name, params):
    strategy = strategies.get(name, **params)
    inputs = make_inputs()
    with pytest.raises(ValueError, match="budget"):
        strategy.select(inputs, -1, np.random.default_rng(0))
    with pytest.raises(ValueError, match="rng"):
        strategy.select(inputs, 3, 0)
    bare = StrategyInputs(unlabeled_idx=inputs.unlabeled_idx, labeled_idx=inputs.labeled_idx)
    if strategy.needs:
        with pytest.raises(ValueError, match="lack"):
            strategy.select(bare, 3, np.random.default_rng(0))
    empty = StrategyInputs(unlabeled_idx=[], labeled_idx=inputs.labeled_idx)
    assert strategy.select(empty, 3, np.random.default_rng(0)).tolist() == []


def test_selection_interface_has_no_way_to_receive_labels():
    label_words = ("label", "target", "mask", "oracle", "y")
    fields = [f for f in inspect.signature(StrategyInputs).parameters if f != "labeled_idx"]
    assert not [f for f in fields if any(w == f or w + "s" == f for w in label_words)]
    assert list(inspect.signature(strategies.Strategy.select).parameters) == [
        "self", "inputs", "budget", "rng"
    ]  # fmt: skip


def test_selection_needs_neither_torch_nor_sklearn():
    code = (
        "import sys, numpy as np; import spl_al.strategies as s, spl_al.pool;"
        "from spl_al.strategies.inputs import StrategyInputs;"
        "x = np.random.default_rng(0).normal(size=(50, 3));"
        "i = StrategyInputs(np.arange(50), [], group_features=x, gamma=x[:, 0],"
        " inconsistency=x[:, 1]);"
        "s.get('duis', n_cand=10).select(i, 3, np.random.default_rng(0));"
        "assert 'torch' not in sys.modules and 'sklearn' not in sys.modules, 'heavy import'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)

"""TypiClust, ProbCover, MaxHerding and DropQuery as their papers and reference code run
them: the settings that make them so, each checked on a fixture where the other
setting picks otherwise."""

import numpy as np
import pytest

from spl_al import strategies
from spl_al.strategies import StrategyInputs
from spl_al.strategies.dropquery import dropout_disagreements
from spl_al.strategies.probcover import purity_radius


def _blobs(n_unl=300, n_lab=12, d=16, seed=0, k=5, spread=0.25):
    rng = np.random.default_rng(seed)
    centres = rng.normal(0, 1.0, (k, d)) + 3.0  # away from the origin: directions differ
    x = centres[rng.integers(0, k, n_unl + n_lab)] + rng.normal(0, spread, (n_unl + n_lab, d))
    order = rng.permutation(n_unl + n_lab)
    return x, order


def _inputs(x, order, n_lab, scale=None):
    n_unl = len(x) - n_lab
    if scale is not None:  # each feature vector by its own positive factor
        x = x * scale[:, None]
    return StrategyInputs(
        unlabeled_idx=order[:n_unl],
        labeled_idx=order[n_unl:],
        features=x[:n_unl].astype(np.float32),
        labeled_features=x[n_unl:].astype(np.float32),
    )


@pytest.mark.parametrize(("name", "params"), [("typiclust", {}), ("probcover", {"n_classes": 5})])
def test_scaling_each_feature_vector_leaves_the_picks_unchanged(name, params):
    """Their reference code L2-normalises every feature vector first: only its direction
    counts, so a per-sample scale (an embedding's norm) cannot move a pick."""
    x, order = _blobs()
    scale = np.random.default_rng(5).uniform(0.5, 60.0, len(x))
    strategy = strategies.get(name, **params)
    plain = strategy.select(_inputs(x, order, 12), 15, np.random.default_rng(3))
    scaled = strategy.select(_inputs(x, order, 12, scale), 15, np.random.default_rng(3))
    assert plain.tolist() == scaled.tolist()


def _clump_and_blob():
    """One cluster: a tight clump of 6 samples (rows 0-5), and a broad blob of 40 (rows
    6-45). A sample of the clump has the 5 nearest neighbours closest; a sample inside
    the blob has the 20 nearest closest (the clump's 20 reach across to the blob)."""
    rng = np.random.default_rng(0)
    plane = np.concatenate(
        [
            np.array([[6.0, 0.0]]) + rng.normal(0, 0.02, (6, 2)),  # clump: rows 0-5
            np.array([[0.0, 0.0]]),  # the blob's centre: row 6
            rng.normal(0, 1.0, (39, 2)),  # the rest of the blob: rows 7-45
        ]
    )
    # on the plane z = 20, so the unit-length features keep the plane's geometry
    x = np.concatenate([plane, np.full((len(plane), 1), 20.0)], axis=1)
    return StrategyInputs(
        unlabeled_idx=np.arange(len(x)),
        labeled_idx=np.zeros(0, dtype=np.int64),
        features=x.astype(np.float32),
        labeled_features=np.zeros((0, 3), dtype=np.float32),
    )


def test_typiclust_measures_typicality_over_20_neighbours():
    inputs = _clump_and_blob()
    # one batch sample, no label: k-means into one cluster, its most typical sample
    assert strategies.get("typiclust").select(inputs, 1, np.random.default_rng(0))[0] >= 6
    # scikit-activeml's k = 5 (and a k_nn of 5 here) would take the clump
    five = strategies.get("typiclust", k_nn=5).select(inputs, 1, np.random.default_rng(0))
    assert five[0] < 6


def test_typiclust_drops_small_clusters_and_records_its_clusters():
    x, order = _blobs(n_unl=200, n_lab=20)
    strategy = strategies.get("typiclust")
    picks = strategy.select(_inputs(x, order, 20), 10, np.random.default_rng(1))
    decision = strategy.decision
    assert decision["clusters"] == 30  # |L| + B
    assert decision["clusters_used"] + decision["clusters_dropped"] == 30
    assert decision["clusters_dropped"] >= 1  # 220 samples in 30 clusters: some of <= 5
    assert len(set(picks.tolist())) == 10


def test_probcover_radius_meets_the_purity_rule_whatever_the_norms_and_stays_fixed():
    """Feature norms near 50 (far outside scikit-activeml's 0.2..2.0 grid): delta is the
    radius at 95% pure balls on the unit-length features, and the same in every round."""
    x, order = _blobs(n_unl=300, n_lab=12, spread=0.6)
    x = 50 * x / np.linalg.norm(x, axis=1, keepdims=True)
    strategy = strategies.get("probcover", n_classes=5)
    inputs = _inputs(x, order, 12)
    deltas = []
    for _round in range(3):
        picks = strategy.select(inputs, 10, np.random.default_rng(_round))
        d = strategy.decision
        assert d["purity"] >= 0.95 and 0 < d["delta"] < 2
        assert d["coverage_before"] <= d["coverage_after"] <= 1
        deltas.append(d["delta"])
        lab = np.concatenate([inputs.labeled_idx, picks])
        unl = np.setdiff1d(inputs.unlabeled_idx, picks)
        rows = {i: r for r, i in enumerate(order)}
        n_unl = len(unl)
        feats = np.concatenate([x[[rows[i] for i in unl]], x[[rows[i] for i in lab]]])
        inputs = StrategyInputs(
            unlabeled_idx=unl,
            labeled_idx=lab,
            features=feats[:n_unl].astype(np.float32),
            labeled_features=feats[n_unl:].astype(np.float32),
        )
    assert deltas[0] == deltas[1] == deltas[2]


def test_purity_radius_by_hand():
    """Points on a line: cluster 0 at 0, 1, 2 and cluster 1 at 5, 6, 10. Distances to the
    other cluster: 5, 4, 3 and 3, 4, 8. At purity 0.5 delta is the floor(6 * 0.5) = 3rd
    smallest, 4, where 4 of 6 balls (radius < 4) are pure."""
    x = np.array([[0.0], [1], [2], [5], [6], [10]], dtype=np.float32)
    delta, purity = purity_radius(x, np.array([0, 0, 0, 1, 1, 1]), 0.5)
    assert delta == pytest.approx(4.0) and purity == pytest.approx(4 / 6)


def test_probcover_falls_back_to_random_picks_when_everything_is_covered():
    x, order = _blobs(n_unl=60, n_lab=30, k=2, spread=0.05)
    strategy = strategies.get("probcover", n_classes=2)
    picks = strategy.select(_inputs(x, order, 30), 5, np.random.default_rng(0))
    assert strategy.decision["coverage_before"] == 1.0
    assert strategy.decision["random_picks"] == 5 and len(set(picks.tolist())) == 5


def test_maxherding_kernel_tells_near_from_far_at_the_papers_bandwidth():
    pytest.importorskip("skactiveml")
    strategy = strategies.get("maxherding")
    a = np.array([[1.0, 0.0, 0.0]])
    near, far = np.array([[1.0, 0.1, 0.0]]), np.array([[0.0, 1.0, 0.0]])  # ~0.1 and 1.41 apart
    k_near, k_far = strategy.kernel(a, near)[0, 0], strategy.kernel(a, far)[0, 0]
    assert k_near > 0.98 and k_far < 0.15  # exp(-0.01) and exp(-2)
    assert strategy.params() == {"bandwidth": 1.0}
    # scikit-activeml's default gamma = 1/d hardly separates them: exp(-2/128) = 0.98
    from sklearn.metrics import pairwise_kernels

    d = 128
    assert pairwise_kernels(a, far / np.linalg.norm(far), metric="rbf", gamma=1 / d)[0, 0] > 0.98
    with pytest.raises(ValueError, match="bandwidth"):
        strategies.get("maxherding", bandwidth=0)


def _head_inputs(n=200, seed=0):
    """Features with a linear head over 3 blocks of 13 features, one block per class:
    rows 0-49 hold blocks 0 and 1 alike (a tie between classes 0 and 1, broken by the
    noise: dropout flips it), the rest block 2 alone (13 features of evidence: dropout
    keeps some of them)."""
    rng = np.random.default_rng(seed)
    c, block = 3, 13
    w = np.kron(np.eye(c), np.ones((1, block)))  # (3, 39)
    f = np.abs(rng.normal(0, 0.01, (n, c * block)))
    f[:50, : 2 * block] += 1.0
    f[50:, 2 * block :] += 1.0
    return StrategyInputs(
        unlabeled_idx=np.arange(n),
        labeled_idx=np.arange(n, n + 5),
        features=f.astype(np.float32),
        labeled_features=f[:5].astype(np.float32),
        head_weight=w.astype(np.float32),
        head_bias=np.zeros(c),
        head_dropout=np.float64(0.75),
    )


def test_dropquery_picks_among_the_samples_whose_prediction_dropout_changes():
    inputs = _head_inputs()
    changed = dropout_disagreements(
        inputs.features,
        inputs.head_weight,
        inputs.head_bias,
        passes=3,
        dropout=0.75,
        rng=np.random.default_rng(0),
    )
    assert changed[:50].mean() > 1 and (changed[50:] == 0).mean() > 0.9
    # no dropout, no change
    none = dropout_disagreements(
        inputs.features, inputs.head_weight, inputs.head_bias, passes=3, dropout=0.0,
        rng=np.random.default_rng(0),
    )  # fmt: skip
    assert not none.any()
    strategy = strategies.get("dropquery")
    picks = strategy.select(inputs, 8, np.random.default_rng(1))
    d = strategy.decision
    assert d["passes"] == 3 and d["dropout"] == 0.75 and d["candidates"] >= 8
    assert len(set(picks.tolist())) == 8
    # every pick passed the rule: its prediction changed in more than half of the passes
    again = dropout_disagreements(
        inputs.features, inputs.head_weight, inputs.head_bias, passes=3, dropout=0.75,
        rng=np.random.default_rng(1),
    )  # fmt: skip
    assert (2 * again[picks] > 3).all()


def test_dropquery_queries_at_the_dropout_its_classifier_trained_with():
    inputs = _head_inputs()
    inputs.head_dropout = np.float64(0.5)  # the supervised CNN's default
    strategy = strategies.get("dropquery")
    strategy.select(inputs, 8, np.random.default_rng(1))
    assert strategy.decision["dropout"] == 0.5 and strategy.params()["dropout"] is None
    # an explicit rate overrides it
    fixed = strategies.get("dropquery", dropout=0.25)
    fixed.select(inputs, 8, np.random.default_rng(1))
    assert fixed.decision["dropout"] == 0.25
    # a classifier trained without dropout gives none to query at: one sentence
    inputs.head_dropout = np.float64(0.0)
    with pytest.raises(ValueError, match="trained without dropout") as err:
        strategy.select(inputs, 8, np.random.default_rng(1))
    assert str(err.value).count(". ") == 0


def test_dropquery_clusters_features_standardised_by_the_labeled_set():
    from spl_al.strategies.dropquery import standardised

    rng = np.random.default_rng(0)
    labeled = rng.normal([5.0, -2.0], [10.0, 0.1], size=(400, 2))
    z = standardised(labeled, labeled)
    assert np.allclose(z.mean(axis=0), 0, atol=1e-5) and np.allclose(z.std(axis=0), 1, atol=1e-3)
    # a feature constant on the labeled set is scaled by BatchNorm's epsilon, not 0
    flat = np.c_[labeled[:, 0], np.ones(400)]
    assert np.isfinite(standardised(flat + 1, flat)).all()


def test_dropout_head_trains_under_its_dropout_like_the_reference():
    from spl_al.linear_probe import HEAD_DROPOUT, DropoutHead

    rng = np.random.default_rng(0)
    centres = rng.normal(0, 1, (3, 16))
    y = np.repeat(np.arange(3), 40)
    x = centres[y] + rng.normal(0, 0.3, (120, 16)) + 4.0  # off-centre: the head standardises
    head = DropoutHead(4, HEAD_DROPOUT).fit(x, y, np.random.default_rng(1))
    w, b, p = head.head()
    assert p == 0.75 and w.shape == (4, 16) and b.shape == (4,)
    assert ((x @ w.T + b).argmax(axis=1) == y).mean() > 0.95  # class 3: never labeled
    assert 20 < head.epochs <= 400  # stopped by the loss plateau or the epoch cap
    again = DropoutHead(4).fit(x, y, np.random.default_rng(1)).head()
    assert np.array_equal(again[0], w)  # the same masks and start from the same rng
    with pytest.raises(ValueError, match="dropout"):
        DropoutHead(4, dropout=1.0)


def test_dropquery_fills_a_short_candidate_set_with_the_most_changed():
    inputs = _head_inputs()
    strategy = strategies.get("dropquery")
    picks = strategy.select(inputs, 80, np.random.default_rng(1))
    assert strategy.decision["filled_by_changes"] == 80 - strategy.decision["candidates"]
    assert len(set(picks.tolist())) == 80
    changed = dropout_disagreements(
        inputs.features, inputs.head_weight, inputs.head_bias, passes=3, dropout=0.75,
        rng=np.random.default_rng(1),
    )  # fmt: skip
    assert set(np.flatnonzero(2 * changed > 3)) <= set(picks.tolist())  # every candidate


@pytest.mark.parametrize(
    ("name", "params", "words"),
    [
        ("probcover", {"n_classes": 11, "purity": 1.5}, "purity"),
        ("probcover", {"n_classes": 11, "purity": 0}, "purity"),
        ("typiclust", {"k_nn": 0}, "k_nn"),
        ("dropquery", {"dropout": 1.0}, "dropout"),
        ("dropquery", {"passes": 0}, "passes"),
    ],
)
def test_bad_parameters_are_refused_in_one_sentence(name, params, words):
    with pytest.raises(ValueError, match=words):
        strategies.get(name, **params)


def test_probcover_without_a_class_count_builds_but_never_selects():
    """A training step builds the strategy for its needs alone, without parameters; a
    selection needs the class count (a plan without it is refused before any job)."""
    strategy = strategies.get("probcover")
    assert strategy.needs == {"features", "labeled_features"}
    x, order = _blobs(n_unl=40, n_lab=5)
    with pytest.raises(ValueError, match="needs n_classes"):
        strategy.select(_inputs(x, order, 5), 3, np.random.default_rng(0))


def test_a_supervised_query_records_what_the_strategy_decided(tmp_path):
    from spl_al.experiment.round0 import write_initial_set
    from spl_al.experiment.round_steps import query_round

    x, order = _blobs(n_unl=100, n_lab=10)
    inputs = _inputs(x, order, 10)
    inputs.save(tmp_path / "scores.npz")
    write_initial_set(inputs.labeled_idx, 1, tmp_path / "labeled.json")
    record = query_round(
        tmp_path / "scores.npz",
        tmp_path / "labeled.json",
        method={"strategy": "probcover", "params": {"n_classes": 5}},
        batch=6,
        seed=1,
        round_=1,
        out_path=tmp_path / "query.json",
    )
    assert set(record["decision"]) >= {"delta", "purity", "coverage_before", "coverage_after"}
    assert len(record["queried"]) == 6


def _config_with(method: dict, dataset: str = "real_cls", framework: str = "supervised"):
    from pathlib import Path

    import yaml

    root = Path(__file__).resolve().parents[1] / "config"
    config = yaml.safe_load((root / "config.yaml").read_text())
    if dataset == "street_seg":
        config["only_datasets"] = ["street_seg"]
    config["methods"]["mine"] = method
    entry = config["datasets"][dataset]
    embedded = framework == "embedding"
    experiments = entry["embedding"]["experiments"] if embedded else entry["experiments"]
    experiments["budget"]["methods"].append("mine")
    return config


@pytest.mark.parametrize(
    ("method", "dataset", "words"),
    [
        (
            {"strategy": "probcover", "params": {"n_classes": 9, "purity": 1.2}},
            "real_cls",
            "purity",
        ),
        ({"strategy": "typiclust", "params": {"k_nn": 0}}, "real_cls", "k_nn"),
        ({"strategy": "dropquery", "params": {"dropout": 1.0}}, "real_cls", "dropout"),
        ({"strategy": "dropquery", "features": "embedding"}, "real_cls", "['head']"),
        ({"strategy": "dropquery"}, "street_seg", "segmentation dataset"),
        ({"strategy": "probcover"}, "real_cls", "needs n_classes"),
    ],
)
def test_the_plan_refuses_a_strategy_it_cannot_run_naming_the_key(method, dataset, words):
    from spl_al.experiment.plan import check_plan

    with pytest.raises(ValueError) as err:
        check_plan(_config_with(method, dataset))
    message = str(err.value)
    assert message.startswith("config key 'methods.mine") and words in message, message
    assert message.count(". ") == 0, message


def test_the_default_run_compares_duis_with_dropquery_in_the_embedding_framework():
    from spl_al.experiment.plan import budget_families, check_plan

    config = _config_with({"strategy": "random"}, "real_cls", "embedding")
    check_plan(config)
    for dataset in ("real_cls", "synth_cls"):
        families = budget_families(config, dataset, framework="embedding")
        assert "dropquery" in families["paper"] and "syn_dropquery" in families["matched"]


def test_a_supervised_dropquery_query_reads_the_saved_head(tmp_path):
    """The scores file a training step saves carries the classifier head; the query step
    reads it back and records the candidate count."""
    from spl_al.experiment.round0 import write_initial_set
    from spl_al.experiment.round_steps import query_round

    inputs = _head_inputs()
    inputs.save(tmp_path / "scores.npz")
    write_initial_set(inputs.labeled_idx, 1, tmp_path / "labeled.json")
    record = query_round(
        tmp_path / "scores.npz",
        tmp_path / "labeled.json",
        method={"strategy": "dropquery"},
        batch=8,
        seed=1,
        round_=1,
        out_path=tmp_path / "query.json",
    )
    assert record["decision"]["candidates"] >= 8 and len(record["queried"]) == 8


def test_probcover_balls_are_symmetric_and_hold_their_centres():
    from spl_al.strategies.probcover import ball_graph

    rng = np.random.default_rng(0)
    x = rng.normal(size=(300, 8)).astype(np.float32)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    indptr, indices = ball_graph(x, 0.9)
    pairs = {(i, int(j)) for i in range(300) for j in indices[indptr[i] : indptr[i + 1]]}
    assert all((j, i) in pairs for i, j in pairs) and all((i, i) in pairs for i in range(300))
    d = np.linalg.norm(x[:, None] - x[None], axis=-1)
    assert pairs <= {(i, j) for i, j in zip(*np.nonzero(d < 0.9 + 1e-5), strict=True)}

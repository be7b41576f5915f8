"""The dense self-supervised encoder and the per-pixel probe (segmentation's embedding).

What a user relies on: the two views' pixels and regions correspond (a positive pair
is one surface), the encoder is reproducible from its seed and reads no label, and the
probe weighs classes as the networks do and always answers with C columns.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest
import torch

from spl_al.data import Dataset
from spl_al.dense_probe import DenseProbe, class_weights
from spl_al.training.dense_contrastive import (
    DenseEncoderConfig,
    _pair,
    _region_pairs,
    _sample_pixels,
    dense_features,
    scan_regions,
    train_dense_encoder,
)

N, G, H, W = 6, 3, 16, 32


def scans(seed: int = 0):
    """N street-like scans of G images: a ground plane below, a wall with a box in front."""
    rng = np.random.default_rng(seed)
    rows = np.arange(H)[:, None] * np.ones((1, W))
    depth = np.empty((N, G, H, W))
    for i in range(N):
        base = np.where(rows > H // 2, 20.0 / np.maximum(rows - H // 2 + 1, 1), rng.uniform(15, 25))
        c0 = rng.integers(0, W - 8)
        base[4:10, c0 : c0 + 8] = rng.uniform(5, 8)
        depth[i] = base[None] + rng.normal(0, 0.02, (G, H, W))
    valid = rng.random(depth.shape) > 0.1
    valid[:, :, :2] = False  # the sky
    return np.where(valid, depth, np.nan), valid


def test_regions_are_numbered_per_scan_and_split_at_depth_edges():
    depth, valid = scans()
    regions = scan_regions(depth[:, 0], valid[:, 0], cell=(8, 16), depth_step=0.15)
    assert regions.shape == (N, H, W)
    assert ((regions == -1) == ~valid[:, 0]).all()
    for i in range(N):
        ids = np.unique(regions[i][regions[i] >= 0])
        np.testing.assert_array_equal(ids, np.arange(len(ids)))
        for r in ids:
            rr, cc = np.nonzero(regions[i] == r)
            assert len(set((rr // 8 * 100 + cc // 16).tolist())) == 1  # one grid cell
            d = depth[i, 0][rr, cc]
            assert d.max() / d.min() < 1.16  # the box and the wall behind are apart


@pytest.mark.parametrize("objective", ["siv", "generic"])
def test_positive_pixels_and_regions_are_the_same_place_in_both_views(objective):
    """Each scan's column index as its depth: a sampled pixel of view a and its pair in
    view b read the same column of the scan, a region's pixels the same region."""
    n, g, h, w = 4, 2, 8, 24
    col = np.broadcast_to(np.arange(1.0, w + 1), (n, g, h, w)).copy()
    x_all = torch.stack([torch.from_numpy(col), torch.ones(n, g, h, w, dtype=torch.float64)], 2)
    cfg = DenseEncoderConfig(crop=0.5, objective=objective, noise=0.0, pixel_dropout=0.0)
    gen = torch.Generator().manual_seed(0)
    scans_ = torch.arange(n)
    for _ in range(5):
        view_a, view_b, sa, sb, width = _pair(x_all.float(), scans_, gen, cfg)
        rows, in_a, in_b = _sample_pixels(
            view_a, view_b, start_a=sa, start_b=sb, width=width, n_pixels=10, gen=gen
        )
        assert len(rows) == n * 10
        at_a = view_a[rows, 0].flatten(1)[torch.arange(len(rows)), in_a]
        at_b = view_b[rows, 0].flatten(1)[torch.arange(len(rows)), in_b]
        torch.testing.assert_close(at_a, at_b)
        # regions numbered by column: a region's mean column is the same in both views
        regions = torch.from_numpy(np.broadcast_to(np.arange(w) // 3, (n, h, w)).copy())
        feats = torch.cat([view_a, view_b])[:, :1]  # the column as a 1-d "feature"
        fa, fb = _region_pairs(
            feats,
            view_a,
            view_b,
            regions=regions,
            start_a=sa,
            start_b=sb,
            width=width,
            min_pixels=1,
        )
        assert len(fa) > 0
        torch.testing.assert_close(fa, fb)


@pytest.mark.parametrize("unit", ["pixel", "region"])
def test_the_encoder_is_its_seed_and_gives_a_feature_per_pixel(unit):
    depth, valid = scans()
    cfg = DenseEncoderConfig(width=4, depth=2, steps=3, batch_size=4, pixels=8, unit=unit)
    runs = [train_dense_encoder(depth, valid, cfg=cfg, log="/dev/null") for _ in range(2)]
    feats = [dense_features(enc, depth[:, 0], valid[:, 0]) for enc, _ in runs]
    np.testing.assert_array_equal(feats[0], feats[1])
    assert feats[0].shape == (N, H, W, 4) and np.isfinite(feats[0]).all()
    levels = dense_features(runs[0][0], depth[:, 0], valid[:, 0], levels=3)
    assert levels.shape == (N, H, W, 4 + 8 + 16)  # the decoder's levels and the bottleneck
    np.testing.assert_allclose(levels[..., :4], feats[0], rtol=1e-5, atol=1e-6)
    record = runs[0][1]
    assert record["steps"] == 3 and record["final_loss"] < record["chance_loss"] * 1.5
    other = train_dense_encoder(
        depth, valid, cfg=DenseEncoderConfig(**{**cfg.as_dict(), "seed": 1})
    )
    assert not np.array_equal(dense_features(other[0], depth[:, 0], valid[:, 0]), feats[0])


def test_a_bad_recipe_is_one_sentence():
    with pytest.raises(ValueError, match=r"objective must be one of \['siv', 'generic'\]"):
        DenseEncoderConfig.from_dict({"objective": "mae"})
    with pytest.raises(ValueError, match=r"unit must be one of \['pixel', 'region'\]"):
        DenseEncoderConfig.from_dict({"unit": "scan"})
    with pytest.raises(ValueError, match="unknown keys"):
        DenseEncoderConfig.from_dict({"widht": 8})
    depth, valid = scans()
    with pytest.raises(ValueError, match=r"must both be \(N, G, H, W\)"):
        train_dense_encoder(depth[:, 0], valid[:, 0], cfg=DenseEncoderConfig())


def test_class_weights_are_the_networks_balance():
    y = np.array([0] * 900 + [1] * 100)
    w = class_weights(y, 3, 0.5)
    assert w[2] == 0 and w[1] / w[0] == pytest.approx(3.0)  # (900 / 100) ** 0.5
    assert (w[y]).mean() == pytest.approx(1.0)
    np.testing.assert_allclose(class_weights(y, 3, 0.0)[:2], [1.0, 1.0])


def test_the_probe_answers_c_columns_and_separates_what_is_separable():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(3000, 4))
    y = (x[:, 0] > 0).astype(int) * 2  # classes 0 and 2 of 4
    probe = DenseProbe(4, max_pixels=1000).fit(x, y, np.random.default_rng(1))
    p = probe.predict_proba(x)
    assert p.shape == (3000, 4) and np.allclose(p.sum(1), 1) and (p[:, [1, 3]] == 0).all()
    assert (p.argmax(1) == y).mean() > 0.97
    again = DenseProbe(4, max_pixels=1000).fit(x, y, np.random.default_rng(1))
    np.testing.assert_array_equal(again.predict_proba(x), p)
    one = DenseProbe(4).fit(x[:5], np.full(5, 3), np.random.default_rng(0))
    assert (one.predict_proba(x[:2])[:, 3] == 1).all()
    with pytest.raises(ValueError, match="at least one labeled pixel"):
        DenseProbe(4).fit(x[:0], y[:0], np.random.default_rng(0))


def dense_pool(n=10, g=3, units=20, d=3, seed=0):
    """(n, g, units, d) features, (n, g, units) validity and (n, units) classes."""
    rng = np.random.default_rng(seed)
    feats = rng.normal(size=(n, g, units, d)).astype(np.float32)
    valid = rng.random((n, g, units)) > 0.2
    labels = (feats[:, 0, ..., 0] > 0).astype(int) + (feats[:, 0, ..., 1] > 0)
    return feats, valid, labels


def test_dense_probe_inputs_give_duis_the_papers_units():
    """gamma: the margin of the images' mean probabilities, averaged over the observed
    scan's valid pixels; a scan whose variants see what it sees is consistent (d = 0);
    DUIS picks distinct unlabeled scans from them."""
    from spl_al.dense_probe import dense_probe_inputs, pooled_features
    from spl_al.strategies import get

    feats, valid, labels = dense_pool()
    labeled, unlabeled = np.array([0, 1, 2]), np.arange(3, 10)
    keep = valid[labeled, 0]
    probe = DenseProbe(3).fit(
        feats[labeled, 0][keep], labels[labeled][keep], np.random.default_rng(0)
    )
    feats[4, 1:], valid[4, 1:] = feats[4, :1], valid[4, :1]  # scan 4: its variants see it alike
    duis = get("duis", n_cand=3)
    inputs = dense_probe_inputs(
        probe, feats, valid, duis.needs, unlabeled_idx=unlabeled, labeled_idx=labeled, n_images=3
    )
    q = probe.predict_proba(feats[3].reshape(-1, 3)).reshape(3, -1, 3)  # scan 3's images
    both = valid[3].reshape(3, -1)
    qbar = (q * both[..., None]).sum(0) / np.maximum(both.sum(0), 1)[:, None]
    top = np.sort(qbar, axis=1)
    expected = (top[:, -1] - top[:, -2])[both[0]].mean()
    assert inputs.gamma[0] == pytest.approx(expected, rel=1e-5)
    assert inputs.inconsistency[1] == pytest.approx(0.0, abs=1e-9) and inputs.inconsistency[0] > 0
    np.testing.assert_allclose(
        inputs.group_features[0],
        pooled_features(feats[3], np.repeat(valid[3, :1], 3, 0)).mean(0),
        rtol=1e-5,
    )
    picks = duis.select(inputs, 3, np.random.default_rng(0))
    assert len(set(picks.tolist())) == 3 and set(picks.tolist()) <= set(unlabeled.tolist())


def pool_inputs(probe, feats, valid, strategy, split, head=None):
    """``dense_probe_inputs`` for ``strategy`` on one image a group; ``split``:
    (unlabeled, labeled) indices."""
    from spl_al.dense_probe import dense_probe_inputs

    unlabeled, labeled = split
    return dense_probe_inputs(
        probe, feats, valid, strategy.needs, unlabeled_idx=unlabeled, labeled_idx=labeled,
        n_images=1, head=head,
    )  # fmt: skip


def test_dense_probe_inputs_serve_every_segmentation_strategy():
    from spl_al.strategies import get

    feats, valid, labels = dense_pool(seed=1)
    labeled, unlabeled = np.array([0, 1]), np.arange(2, 10)
    keep = valid[labeled, 0]
    probe = DenseProbe(3).fit(
        feats[labeled, 0][keep], labels[labeled][keep], np.random.default_rng(0)
    )
    for name in ("entropy", "margin", "coreset", "badge", "typiclust", "probcover"):
        strategy = get(name)
        inputs = pool_inputs(probe, feats, valid, strategy, (unlabeled, labeled))
        if getattr(strategy, "n_classes", 0) is None:
            strategy.n_classes = 3
        picks = strategy.select(inputs, 2, np.random.default_rng(0))
        assert len(set(picks.tolist())) == 2 and set(picks.tolist()) <= set(unlabeled.tolist())
    with pytest.raises(ValueError, match="takes a head"):
        pool_inputs(probe, feats, valid, get("dropquery"), (unlabeled, labeled))


def test_dropquery_passes_a_head_over_the_pooled_features():
    """DropQuery in the dense setting: a dropout-trained head on the labeled units,
    its passes over each scan's pooled features (the mean of its units' logits)."""
    from spl_al.dense_probe import pooled_features
    from spl_al.linear_probe import DropoutHead
    from spl_al.strategies import get

    feats, valid, labels = dense_pool(seed=2)
    labeled, unlabeled = np.array([0, 1, 2]), np.arange(3, 10)
    keep = valid[labeled, 0]
    x, y = feats[labeled, 0][keep], labels[labeled][keep]
    probe = DenseProbe(3).fit(x, y, np.random.default_rng(0))
    head = DropoutHead(3).fit(x, y, np.random.default_rng(0)).head()
    strategy = get("dropquery")
    inputs = pool_inputs(probe, feats, valid, strategy, (unlabeled, labeled), head=head)
    np.testing.assert_allclose(
        inputs.features, pooled_features(feats[unlabeled, 0], valid[unlabeled, 0]), rtol=1e-5
    )
    np.testing.assert_array_equal(inputs.head_weight, head[0])
    picks = strategy.select(inputs, 2, np.random.default_rng(0))
    assert len(set(picks.tolist())) == 2 and set(picks.tolist()) <= set(unlabeled.tolist())


DENSE_ENCODER = {
    "width": 8,
    "depth": 2,
    "projection_dim": 8,
    "steps": 30,
    "batch_size": 6,
    "pixels": 32,
}
DENSE_VARIANTS = {"n": 2, "shards": 1, "seed": 0}


@pytest.fixture(scope="module")
def street(tmp_path_factory):
    """A small segmentation dataset with 2 variants a scan, and one dense encoder's files."""
    from spl_al.data import make_segmentation_dataset
    from spl_al.data.variants import make_variants
    from spl_al.experiment.embedding_steps import train_encoder

    folder = tmp_path_factory.mktemp("street")
    data = make_segmentation_dataset(n_samples=40, image_shape=(16, 32), seed=0)
    data = make_variants(data, n_variants=2, seed=0)
    path = folder / "dataset.npz"
    data.save(path)
    out = {k: folder / f"enc.{k}" for k in ("encoder", "card", "embeddings")}
    card = train_encoder(
        path, dataset="street", encoder=DENSE_ENCODER, variants=DENSE_VARIANTS, out=out
    )
    return path, Dataset.load(path), out, card


def test_a_dense_encoder_keeps_the_same_units_of_every_image_and_every_test_pixel(street):
    """The embeddings a segmentation run reads: each training scan's units, drawn from
    its observed valid pixels, at the same places in its variants; every valid test
    pixel; the encoder's features beside the nine local ones."""
    from spl_al.experiment.dense_embedding import UNITS_PER_SCAN

    _, data, out, card = street
    with np.load(out["embeddings"]) as f:
        train, units, tvalid, test = f["train"], f["train_units"], f["train_valid"], f["test"]
        test_units = f["test_units"]
    n = len(data.train_idx)
    _, valid = data.groups(data.train_idx)
    assert train.shape == (n, 3, UNITS_PER_SCAN, 8 + 9) and train.dtype == np.float16
    flat = valid.reshape(n, 3, -1)
    for i in range(n):
        held = flat[i, 0, units[i]]
        assert held.sum() == min(flat[i, 0].sum(), UNITS_PER_SCAN)
        np.testing.assert_array_equal(tvalid[i], flat[i][:, units[i]])
    test_valid = np.isfinite(data.depth_m[data.test_idx]).reshape(-1)
    np.testing.assert_array_equal(test_units, np.flatnonzero(test_valid))
    assert len(test) == test_valid.sum()
    assert card["units_per_scan"] == UNITS_PER_SCAN and card["health"]["verdict"] != "collapsed"
    assert card["encoder"]["width"] == 8  # the dense recipe on the card


@pytest.mark.parametrize("strategy", ["duis", "random", "badge", "dropquery", "typiclust"])
def test_dense_runs_keep_the_strategy_contract(street, strategy):
    """Segmentation runs in the embedding framework: mIoU records, distinct unlabeled
    picks, seeded, and the same whatever the pixel classes of scans never labeled."""
    from spl_al.experiment.dense_embedding import load_dense
    from spl_al.experiment.embedding_steps import _run
    from spl_al.experiment.plan import MethodSpec

    _, data, out, _ = street
    facts = load_dense(out["embeddings"], data, n_total=len(data.train_idx), encoder=(0, "healthy"))
    params = {"n_cand": 8} if strategy == "duis" else {}
    spec = MethodSpec(name=strategy, strategy=strategy, params=params, use_variants=True)
    al = {"initial": 4, "batch": 3}

    def sets(f):
        records = _run(f, spec, which=("street", 1), al=al, rounds=3, probe={}, n_variants=2)
        assert all(r["metric"] == "miou" and 0 <= r["value"] <= 1 for r in records)
        return [r["pool_indices"] for r in records]

    first = sets(facts)
    never = np.setdiff1d(np.arange(len(facts.train)), first[-1])
    other = facts.unit_labels.copy()
    other[never] = (other[never] + 1) % len(facts.classes)
    assert sets(replace(facts, unit_labels=other)) == first
    assert sets(facts) == first
    for before, after in itertools.pairwise(first):
        assert len(set(after) - set(before)) == 3 and set(before) <= set(after)


def test_a_dense_embeddings_file_is_refused_where_a_frame_embedding_is_read(street):
    """A supervised method selecting on the embedding (features: embedding) reads frame
    embeddings; a dense encoder's file is refused in one sentence."""
    from spl_al.experiment.encoders import load_embeddings

    _, data, out, _ = street
    with pytest.raises(ValueError, match="dense encoder's per-pixel features"):
        load_embeddings(out["embeddings"], data)


def test_a_probe_started_from_the_last_round_finds_the_same_classifier():
    """A round's fit starts from the previous round's probe: the same predictions as a
    fit from zero, on more labeled pixels."""
    rng = np.random.default_rng(0)
    x = rng.normal(size=(6000, 5)) * [1, 2, 3, 1, 1] + [0, 5, 0, 0, 1]
    y = (x[:, 0] > 0).astype(int) + (x[:, 2] > 1) + (x[:, 3] > 1)
    first = DenseProbe(4).fit(x[:2000], y[:2000], rng)
    cold = DenseProbe(4).fit(x, y, np.random.default_rng(1))
    warm = DenseProbe(4).fit(x, y, np.random.default_rng(1), start=first)
    agree = (cold.predict(x) == warm.predict(x)).mean()
    assert agree > 0.99
    np.testing.assert_allclose(warm.predict_proba(x[:50]).sum(1), 1, rtol=1e-5)


def test_the_dense_bench_probes_sampled_pixels_as_the_rounds_fit_them(street):
    """bench dense --units: the probe reads the labeled scans' sampled valid pixels only
    (the rounds' view); every pixel sampled is the full probe."""
    from spl_al.bench.dense import probe_miou
    from spl_al.experiment.dense_embedding import sample_units

    _, data, _, _ = street
    rng = np.random.default_rng(0)
    feats = np.stack([data.depth_m, np.isfinite(data.depth_m)], -1)
    feats = np.nan_to_num(feats) + rng.normal(size=feats.shape) * 0.01
    labeled, held_out = np.arange(8), np.arange(20, 28)
    kw = dict(seed=1, c=1.0, balance=0.5)
    full = probe_miou(data, feats, labeled, held_out, **kw)
    pixels = int(np.prod(data.depth_m.shape[1:]))
    every = sample_units(data.valid, pixels, rng)
    assert probe_miou(data, feats, labeled, held_out, units=every, **kw) == pytest.approx(
        full, abs=0.02
    )
    few = sample_units(data.valid, 4, rng)
    assert probe_miou(data, feats, labeled, held_out, units=few, **kw) != full


def test_the_probes_solver_reaches_scikit_learns_optimum():
    """fit_multinomial minimises LogisticRegression's objective (L2, intercept, sample
    weights) with its solver settings: the same coefficients from the same start, in
    the same iterations, and from a warm start the same optimum in fewer."""
    from scipy.special import softmax
    from sklearn.linear_model import LogisticRegression

    from spl_al.multinomial import fit_multinomial

    rng = np.random.default_rng(3)
    x = rng.normal(size=(2000, 6))
    y = np.argmax(x[:, :4] + 0.7 * rng.normal(size=(2000, 4)), axis=1)
    w = class_weights(y, 4, 0.5)[y]
    ref = LogisticRegression(C=0.5, max_iter=500, tol=1e-6).fit(x, y, sample_weight=w)
    coef, iterations = fit_multinomial(x, y, w, c=0.5, tol=1e-6)
    np.testing.assert_allclose(coef[:, :-1], ref.coef_, atol=1e-6)
    np.testing.assert_allclose(coef[:, -1], ref.intercept_, atol=1e-6)
    assert iterations == ref.n_iter_[0]
    again, fewer = fit_multinomial(x, y, w, c=0.5, tol=1e-6, coef=coef + 0.01)
    # the same function (a shift common to every intercept changes no probability)
    logits = x @ again[:, :-1].T + again[:, -1]
    np.testing.assert_allclose(softmax(logits, axis=1), ref.predict_proba(x), rtol=0, atol=1e-4)
    assert fewer < iterations

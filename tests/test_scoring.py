"""compute_inputs: only what was needed, consistent with predict, bounded for segmentation."""

import numpy as np
import pytest
from helpers.al_synthetic import shapes_groups, street_groups

from spl_al import strategies
from spl_al.models import build_model
from spl_al.scoring import compute_inputs
from spl_al.strategies import NEEDS, StrategyInputs
from spl_al.strategies.badge import pixel_gradient_embedding
from spl_al.strategies.duis import margin_and_inconsistency
from spl_al.strategies.entropy import entropy_score
from spl_al.strategies.margin import margin_score
from spl_al.training import predict
from spl_al.training.compute import Compute

CPU = Compute("cpu")

ALL_FIELDS = ("entropy", "margin", "gamma", "inconsistency", "features", "group_features")
ALL_FIELDS += ("labeled_features", "grad_q", "grad_h", "grad_embedding", "head_weight", "head_bias")
ALL_FIELDS += ("head_dropout",)


class CountingModel:
    """Wraps a model to count the images it is run on."""

    def __init__(self, model):
        self.model, self.images = model, 0
        self.task, self.n_classes, self.feature_dim = model.task, model.n_classes, model.feature_dim
        self.fc = getattr(model, "fc", None)  # the classifier head (DropQuery's need)
        self.dropout = getattr(model, "dropout", None)  # and the dropout it trained with

    def to(self, device):
        self.model.to(device)
        return self

    def eval(self):
        self.model.eval()
        return self

    def __call__(self, x):
        self.images += len(x)
        return self.model(x)


@pytest.fixture(scope="module")
def cls_setup():
    depth, valid, _ = shapes_groups(20, n_groups=3, size=12)
    model = build_model("classification", 3, width=4, seed=0)
    return model, depth, valid, np.arange(5, 20), np.arange(5)


# the generic scikit-activeml adapter is built with one of its classes
PARAMS = {"skactiveml": {"cls": "TypiClust"}, "probcover": {"n_classes": 3}}


@pytest.mark.parametrize("name", strategies.names())
def test_only_the_needed_parts_are_computed(cls_setup, name):
    model, depth, valid, unl, lab = cls_setup
    needs = strategies.get(name, **PARAMS.get(name, {})).needs
    counting = CountingModel(model)
    inputs = compute_inputs(
        counting,
        needs,
        depth_m=depth,
        valid=valid,
        unlabeled_idx=unl,
        labeled_idx=lab,
        compute=CPU,
    )
    present = {f for f in ALL_FIELDS if getattr(inputs, f) is not None}
    expected = {f for n in needs for f in NEEDS[n]} - {"grad_embedding"}  # classification: q, h
    assert present == expected
    group = bool(needs & strategies.GROUP_NEEDS)
    images = (len(unl) * 3 if group else len(unl)) if needs - {"labeled_features"} else 0
    images += len(lab) if "labeled_features" in needs else 0
    assert counting.images == images


def test_classification_inputs_match_predict(cls_setup):
    model, depth, valid, unl, lab = cls_setup
    inputs = compute_inputs(
        model,
        NEEDS,
        depth_m=depth,
        valid=valid,
        unlabeled_idx=unl,
        labeled_idx=lab,
        compute=CPU,
        batch_size=7,
    )
    n, g = len(unl), depth.shape[1]
    pred = predict(model, depth[unl].reshape(n * g, 12, 12), valid[unl].reshape(n * g, 12, 12))
    probs = pred.probs.reshape(n, g, 1, -1)
    feats = pred.features.reshape(n, g, -1)
    assert np.allclose(inputs.entropy, entropy_score(probs[:, 0]), atol=1e-6)
    assert np.allclose(inputs.margin, margin_score(probs[:, 0]), atol=1e-6)
    gamma, d = margin_and_inconsistency(probs)
    assert np.allclose(inputs.gamma, gamma, atol=1e-6) and np.allclose(
        inputs.inconsistency, d, atol=1e-6
    )
    assert np.allclose(inputs.features, feats[:, 0], atol=1e-5)
    assert np.allclose(inputs.group_features, feats.mean(1), atol=1e-5)
    lab_pred = predict(model, depth[lab, 0], valid[lab, 0])
    assert np.allclose(inputs.labeled_features, lab_pred.features, atol=1e-5)
    onehot = np.eye(3)[probs[:, 0, 0].argmax(1)]
    assert np.allclose(inputs.grad_q, probs[:, 0, 0] - onehot, atol=1e-6)


def test_segmentation_inputs_are_per_group_and_average_observed_valid_pixels():
    depth, valid, _ = street_groups(9, n_groups=2, shape=(10, 14))
    model = build_model("segmentation", 3, width=4, depth=2, seed=0)
    unl, lab = np.array([0, 2, 3, 5, 8]), np.array([1, 4])
    with pytest.raises(ValueError, match="no classifier head"):  # a segmenter has none
        compute_inputs(model, {"features", "head"}, depth_m=depth, valid=valid,
                       unlabeled_idx=unl, labeled_idx=lab, compute=CPU)  # fmt: skip
    inputs = compute_inputs(
        model,
        set(NEEDS) - {"head"},
        depth_m=depth,
        valid=valid,
        unlabeled_idx=unl,
        labeled_idx=lab,
        compute=CPU,
        batch_size=3,
    )
    n, hw = len(unl), 10 * 14
    pred = predict(
        model,
        depth[unl].reshape(n * 2, 10, 14),
        valid[unl].reshape(n * 2, 10, 14),
        features="pixel",
    )
    probs = pred.probs.reshape(n, 2, 3, hw).transpose(0, 1, 3, 2)  # (groups, G, units, C)
    feats = pred.features.reshape(n, 2, 4, hw).transpose(0, 1, 3, 2)
    units = valid[unl, 0].reshape(n, hw)  # the observed image's valid pixels
    assert np.allclose(inputs.entropy, entropy_score(probs[:, 0], units), atol=1e-6)
    assert np.allclose(inputs.margin, margin_score(probs[:, 0], units), atol=1e-6)
    images = valid[unl].reshape(n, 2, hw)  # each image's own valid pixels
    gamma, d = margin_and_inconsistency(probs, units, images)
    assert np.allclose(inputs.gamma, gamma, atol=1e-6) and np.allclose(
        inputs.inconsistency, d, atol=1e-6
    )
    pooled = (feats * units[:, None, :, None]).sum(2) / units.sum(1)[:, None, None]
    assert np.allclose(inputs.features, pooled[:, 0], atol=1e-5)
    assert np.allclose(inputs.group_features, pooled.mean(1), atol=1e-5)
    emb = pixel_gradient_embedding(probs[:, 0], feats[:, 0], units)
    assert inputs.grad_embedding.shape == (n, 3 * 4) and inputs.grad_q is None
    assert np.allclose(inputs.grad_embedding, emb, atol=1e-5)
    for name in set(strategies.names()) - {"dropquery"}:  # (no head: classification only)
        picks = (
            strategies.get(name, n_cand=2)
            if name in ("duis", "diversity")
            else strategies.get(name, **PARAMS.get(name, {}))
        )
        assert len(picks.select(inputs, 2, np.random.default_rng(0))) == 2


def test_groups_without_variants_and_bad_arguments(cls_setup):
    model, depth, valid, unl, lab = cls_setup
    inputs = compute_inputs(
        model,
        {"margin_inconsistency"},
        depth_m=depth[:, :1],
        valid=valid[:, :1],
        unlabeled_idx=unl,
        labeled_idx=lab,
    )
    assert np.allclose(inputs.inconsistency, 0.0, atol=1e-7)  # G = 1: nothing to disagree with
    with pytest.raises(ValueError, match="needs"):
        compute_inputs(
            model, {"probs"}, depth_m=depth, valid=valid, unlabeled_idx=unl, labeled_idx=lab
        )
    with pytest.raises(ValueError, match=r"\(N, G, H, W\)"):
        compute_inputs(
            model,
            {"entropy"},
            depth_m=depth[:, 0],
            valid=valid[:, 0],
            unlabeled_idx=unl,
            labeled_idx=lab,
        )
    with pytest.raises(ValueError, match="overlap"):
        compute_inputs(
            model, {"entropy"}, depth_m=depth, valid=valid, unlabeled_idx=unl, labeled_idx=[5]
        )
    with pytest.raises(ValueError, match="unlabeled_idx"):
        compute_inputs(
            model, {"entropy"}, depth_m=depth, valid=valid, unlabeled_idx=[25], labeled_idx=lab
        )


def test_inputs_save_and_load_atomically(tmp_path, cls_setup):
    model, depth, valid, unl, lab = cls_setup
    inputs = compute_inputs(
        model,
        strategies.get("duis").needs,
        depth_m=depth,
        valid=valid,
        unlabeled_idx=unl,
        labeled_idx=lab,
    )
    path = tmp_path / "round0" / "inputs.npz"
    inputs.save(path)
    assert [p.name for p in path.parent.iterdir()] == ["inputs.npz"]
    back = StrategyInputs.load(path)
    assert back.has("margin_inconsistency") and back.entropy is None
    for f in ("unlabeled_idx", "labeled_idx", "gamma", "inconsistency", "group_features"):
        assert np.array_equal(getattr(back, f), getattr(inputs, f))
    np.savez(tmp_path / "other.npz", labels=np.arange(3))
    with pytest.raises(ValueError, match="not a StrategyInputs"):
        StrategyInputs.load(tmp_path / "other.npz")

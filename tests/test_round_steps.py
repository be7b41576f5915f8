"""Round steps: round 0 fitted and scored once and shared gives what training and
scoring in place give."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from helpers.al_synthetic import shapes_groups

from spl_al.data import Dataset
from spl_al.experiment.round0 import write_initial_set
from spl_al.experiment.round_steps import (
    ModelFiles,
    RoundId,
    RoundStart,
    train_initial,
    train_round,
)
from spl_al.models.configured import save_model
from spl_al.strategies import StrategyInputs
from spl_al.strategies.inputs import ARRAY_FIELDS
from spl_al.training.compute import Compute

SETUP = {
    "train": {
        "model": {"arch": "smallcnn", "width": 4, "stages": 2},
        "fit": {"epochs": 2, "batch_size": 8, "log_every": 0},
    },
    "ratio_of": "train",
}


CPU = Compute("cpu")
ROUND0 = RoundId("toy", "own", 1, 0)


def _files(folder, stem):
    return ModelFiles(folder / f"{stem}.pt", folder / f"{stem}.json", folder / f"{stem}.npz")


def _train(data, labeled, setup, which, out, **options):
    """``train_round`` on the CPU; the module's calls differ in these and ``options``."""
    return train_round(data, labeled, setup=setup, which=which, out=out, compute=CPU, **options)


def _initial(data, labeled, n_variants, out, log):
    """``train_initial`` of ``SETUP``, seed 1, on the CPU."""
    return train_initial(
        data, labeled, setup=SETUP, n_variants=n_variants, seed=1, out=out, compute=CPU, log=log
    )


def _dataset(tmp_path):
    depth, _, labels = shapes_groups(30, n_groups=3, seed=1)
    n = len(labels)
    data = Dataset(
        "classification",
        ["small", "medium", "large"],
        depth[:, 0],
        labels.astype(np.int64),
        ["train"] * 24 + ["test"] * 6,
        np.full(n, 5.0),
        np.full(n, 1.0),
        ["high"] * n,
        variant_depth_m=depth[:, 1:],
        variant_msppp=np.full((n, 2), 2.0),
        variant_sbr=np.full((n, 2), 1.0),
    )
    path = tmp_path / "dataset.npz"
    data.save(path)
    labeled = tmp_path / "initial.json"
    write_initial_set(np.arange(6), 1, labeled)
    return path, labeled


@pytest.mark.parametrize(
    ("method", "m"),
    [
        ({"strategy": "margin"}, 0),
        ({"strategy": "coreset"}, 0),
        ({"strategy": "badge"}, 0),
        ({"strategy": "dropquery"}, 0),
        ({"strategy": "typiclust", "use_variants": True}, 2),
        ({"strategy": "duis", "use_variants": True}, 2),
        ({"strategy": "entropy", "use_variants": True}, 2),
        # trains on observed images, scores on variants: not in the shared scores
        ({"strategy": "duis"}, 0),
    ],
)
def test_shared_round0_equals_training_and_scoring_in_place(tmp_path, method, m):
    data, labeled = _dataset(tmp_path)
    setup = {**SETUP, "method": method}
    own = _train(data, labeled, setup, ROUND0, _files(tmp_path, "own"), log=tmp_path / "own.log")
    initial = ModelFiles(tmp_path / "init.pt", tmp_path / "fit.json", tmp_path / "init.npz")
    fit = _initial(data, labeled, m, initial, tmp_path / "init.log")
    assert fit["dataset"] == {
        "task": "classification", "n_samples": 30, "n_train": 24, "n_variants": 2,
        "synthetic_standin": False,
    }  # fmt: skip
    shared = _train(
        data, labeled, setup, ROUND0, _files(tmp_path, "shared"), start=RoundStart(initial=initial)
    )
    timing = {"train_seconds", "score_seconds", "seconds"}
    assert {k: v for k, v in shared.items() if k not in timing} == {
        k: v for k, v in own.items() if k not in timing
    }
    assert shared["train_images"] == 6 * (m + 1)
    # epochs count the 6 labeled groups (batch 8: one step each), variants or not
    assert (shared["train_steps"], shared["images_seen"]) == (2, 2 * min(8, 6 * (m + 1)))
    assert (fit["train_steps"], fit["images_seen"]) == (2, 2 * min(8, 6 * (m + 1)))
    weights = [torch.load(tmp_path / f, weights_only=True) for f in ("init.pt", "shared.pt")]
    assert all(torch.equal(weights[0][k], weights[1][k]) for k in weights[0])
    a, b = StrategyInputs.load(tmp_path / "own.npz"), StrategyInputs.load(tmp_path / "shared.npz")
    for name in ("unlabeled_idx", "labeled_idx", *ARRAY_FIELDS):
        if getattr(a, name) is None:
            assert getattr(b, name) is None, f"{name}: more than the strategy needs"
        else:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_a_shared_fit_of_other_images_is_refused(tmp_path):
    data, labeled = _dataset(tmp_path)
    initial = ModelFiles(tmp_path / "init.pt", tmp_path / "fit.json", tmp_path / "init.npz")
    _initial(data, labeled, 0, initial, tmp_path / "init.log")
    setup = {**SETUP, "method": {"strategy": "duis", "use_variants": True}}
    duis = RoundId("toy", "duis", 1, 0)
    with pytest.raises(ValueError, match="trained on 6 images, but round 0 of duis trains on 18"):
        _train(data, labeled, setup, duis, _files(tmp_path, "m"), start=RoundStart(initial=initial))


def test_a_last_round_writes_no_scores_and_its_query_is_refused(tmp_path):
    from spl_al.experiment.round_steps import query_round

    data, labeled = _dataset(tmp_path)
    setup = {**SETUP, "method": {"strategy": "margin"}}
    files = _files(tmp_path, "last")
    record = _train(data, labeled, setup, ROUND0, files, score=False)
    assert record["score_seconds"] == 0.0 and (tmp_path / "last.pt").exists()
    scores = StrategyInputs.load(files.scores)
    assert scores.labeled_idx.tolist() == list(range(6)) and len(scores.unlabeled_idx) == 18
    assert all(getattr(scores, f) is None for f in ARRAY_FIELDS)
    with pytest.raises(ValueError, match="margin"):
        query_round(
            files.scores,
            labeled,
            method={"strategy": "margin"},
            batch=2,
            seed=1,
            round_=1,
            out_path=tmp_path / "q.json",
        )


def test_a_warm_start_fine_tunes_the_previous_rounds_weights_with_its_own_steps(tmp_path):
    data, labeled = _dataset(tmp_path)
    setup = {**SETUP, "method": {"strategy": "margin"}}
    first = _files(tmp_path, "r0")
    _train(data, labeled, setup, ROUND0, first, score=False)
    round1 = RoundId("toy", "own", 1, 1)
    # lr 0: a fine-tuning that cannot move the weights returns the previous round's
    warm = {**setup, "train": {**SETUP["train"], "warm_start": {"steps": 3, "lr": 0.0}}}
    record = _train(
        data,
        labeled,
        warm,
        round1,
        _files(tmp_path, "r1"),
        score=False,
        start=RoundStart(previous_model=first.model),
    )
    assert record["train_steps"] == 3  # the warm-start steps, not the fit's 2 epochs
    before, after = (torch.load(tmp_path / f"{r}.pt", weights_only=True) for r in ("r0", "r1"))
    float_keys = [k for k in before if before[k].is_floating_point() and "running" not in k]
    assert float_keys and all(torch.equal(before[k], after[k]) for k in float_keys)
    # without the previous weights the same round trains fresh ones with the fit's steps
    cold = _train(data, labeled, setup, round1, _files(tmp_path, "c1"), score=False)
    assert cold["train_steps"] == 2
    fresh = torch.load(tmp_path / "c1.pt", weights_only=True)
    assert not all(torch.equal(before[k], fresh[k]) for k in float_keys)


def test_the_same_weights_save_to_the_same_bytes(tmp_path):
    """A model card's sha256 names the weights: a rerun that trains the same weights
    must write the same file, whatever temporary name the atomic write used."""
    torch.manual_seed(0)
    model = torch.nn.Linear(3, 2)
    save_model(model, tmp_path / "a" / "model.pt")
    save_model(model, tmp_path / "b" / "model.pt")
    first = (tmp_path / "a" / "model.pt").read_bytes()
    assert first == (tmp_path / "b" / "model.pt").read_bytes()
    state = torch.load(tmp_path / "a" / "model.pt", weights_only=True)
    assert torch.equal(state["weight"], model.weight.detach())


@pytest.mark.parametrize("strategy", ["duis", "diversity", "typiclust", "margin"])
def test_the_same_weights_pick_the_same_groups_whatever_the_training_precision(tmp_path, strategy):
    """Scoring is the acquisition's measurement: the same weights over the same pool give
    the same inputs, so the same picks, whether the round trained in bf16 or in fp32
    (MEASURE_PRECISION). Scored under bf16 autocast instead, the same weights give
    other numbers: the rounding that made verdicts flip between precisions."""
    from spl_al.experiment.plan import MethodSpec
    from spl_al.experiment.pool_scores import score_pool
    from spl_al.models.configured import load_model
    from spl_al.scoring import compute_inputs
    from spl_al.strategies import get

    data_path, labeled = _dataset(tmp_path)
    own = _files(tmp_path, "own")
    _train(data_path, labeled, {**SETUP, "method": {"strategy": "random"}}, ROUND0, own)
    data = Dataset.load(data_path)
    model = load_model(data, SETUP["train"]["model"], own.model)
    method = MethodSpec(strategy, strategy, use_variants=True)
    pool = np.arange(6)
    picks, inputs = {}, {}
    for precision in ("bf16", "fp32"):
        compute = Compute("cpu", precision=precision)
        inputs[precision] = score_pool(model, data, labeled=pool, method=method, compute=compute)
        rng = np.random.default_rng(0)
        params = {"n_cand": 8} if strategy in ("duis", "diversity") else {}
        picks[precision] = get(strategy, **params).select(inputs[precision], 4, rng).tolist()
    for name in ("unlabeled_idx", "labeled_idx", *ARRAY_FIELDS):
        a, b = getattr(inputs["bf16"], name), getattr(inputs["fp32"], name)
        assert (a is None) == (b is None), name
        if a is not None:
            np.testing.assert_array_equal(a, b, err_msg=name)
    assert picks["bf16"] == picks["fp32"]
    # the mechanism: bf16 autocast rounds what a strategy ranks by
    depth, valid = data.groups(data.train_idx, n_variants=2)
    unlabeled = np.setdiff1d(np.arange(len(data.train_idx)), pool)
    needs = {"features", "margin_inconsistency"}
    rounded = [
        compute_inputs(
            model, needs, depth_m=depth, valid=valid, unlabeled_idx=unlabeled,
            labeled_idx=pool, compute=Compute("cpu", precision=p),
        )
        for p in ("bf16", "fp32")
    ]  # fmt: skip
    assert not np.array_equal(rounded[0].features, rounded[1].features)
    assert not np.array_equal(rounded[0].inconsistency, rounded[1].inconsistency)

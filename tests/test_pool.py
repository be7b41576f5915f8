"""Pools, the oracle, the round-0 labeled set, and the label-leakage guarantee."""

import io

import numpy as np
import pytest
from helpers.al_synthetic import shapes_groups

from spl_al import strategies
from spl_al.models import build_model
from spl_al.pool import Oracle, Pool, initial_labeled_set
from spl_al.scoring import compute_inputs
from spl_al.training import TrainConfig, flatten_groups, train
from spl_al.training.compute import Compute

CPU = Compute("cpu")


def test_initial_labeled_set_depends_only_on_its_arguments():
    a = initial_labeled_set(100, 10, seed=1)
    assert a.tolist() == initial_labeled_set(100, 10, seed=1).tolist()
    assert a.tolist() != initial_labeled_set(100, 10, seed=2).tolist()
    assert a.dtype == np.int64 and len(np.unique(a)) == 10 and (np.diff(a) > 0).all()
    assert initial_labeled_set(100, 0, 1).size == 0 and len(initial_labeled_set(5, 5, 1)) == 5
    for bad in ((10, 11), (10, -1)):
        with pytest.raises(ValueError, match="size"):
            initial_labeled_set(*bad, seed=0)


def test_stratified_initial_set_is_balanced():
    labels = np.repeat(np.arange(4), [3, 30, 30, 37])
    s = initial_labeled_set(100, 22, seed=5, labels=labels, stratified=True)
    counts = np.bincount(labels[s], minlength=4)
    assert counts.tolist() in ([3, 7, 6, 6], [3, 6, 7, 6], [3, 6, 6, 7])  # class 0 has only 3
    s2 = initial_labeled_set(100, 22, seed=5, labels=labels, stratified=True)
    assert s.tolist() == s2.tolist()
    with pytest.raises(ValueError, match="labels"):
        initial_labeled_set(100, 22, seed=5, stratified=True)


def test_pool_adds_and_refuses():
    pool = Pool(10, labeled=[7, 2])
    assert pool.labeled_idx.tolist() == [7, 2] and pool.unlabeled_idx.tolist() == [
        0,
        1,
        3,
        4,
        5,
        6,
        8,
        9,
    ]
    pool.add(np.array([0, 9]))
    assert pool.n_labeled == 4 and pool.n_unlabeled == 6
    for bad, match in (([2], "already labeled"), ([1, 1], "duplicate"), ([10], r"\[0, 10\)")):
        with pytest.raises(ValueError, match=match):
            pool.add(bad)
    assert pool.n_labeled == 4  # a refused add changes nothing
    with pytest.raises(ValueError):
        pool.add([1.5])


def test_oracle_reveals_only_queried_labels():
    labels = np.array([3, 1, 4, 1, 5])
    oracle = Oracle(labels)
    labels[0] = 9  # the oracle keeps its own copy
    assert oracle.query([4, 0]).tolist() == [5, 3]
    assert oracle.queried_idx.tolist() == [0, 4]
    got = oracle.query([1])
    got[0] = 7
    assert oracle.query([1]).tolist() == [1]
    with pytest.raises(ValueError):
        oracle.query([5])


def _one_al_round(depth, valid, oracle, labeled, seed):
    """Train on the oracle's labels of the labeled set, score, and select with every strategy."""
    pool = Pool(len(depth), labeled)
    d, v, t = flatten_groups(
        depth[pool.labeled_idx], valid[pool.labeled_idx], oracle.query(pool.labeled_idx)
    )
    model = build_model("classification", 3, width=4)
    cfg = TrainConfig(epochs=3, batch_size=16, log_every=0)
    train(model, d, v, t, cfg=cfg, seed=seed, compute=CPU, log=io.StringIO())
    params = {"duis": {"n_cand": 8}, "diversity": {"n_cand": 8}, "skactiveml": {"cls": "TypiClust"}}
    params["probcover"] = {"n_classes": 3}
    params["dropquery"] = {"dropout": 0.5}  # this model trains without dropout
    built = {n: strategies.get(n, **params.get(n, {})) for n in strategies.names()}
    needs = set().union(*(s.needs for s in built.values()))
    inputs = compute_inputs(
        model,
        needs,
        depth_m=depth,
        valid=valid,
        unlabeled_idx=pool.unlabeled_idx,
        labeled_idx=pool.labeled_idx,
        compute=CPU,
    )
    return {
        name: s.select(inputs, 5, np.random.default_rng(seed)).tolist() for name, s in built.items()
    }


def test_permuting_hidden_labels_leaves_every_selection_unchanged():
    depth, valid, labels = shapes_groups(40, n_groups=3, size=12, seed=3)
    labeled = initial_labeled_set(40, 12, seed=0)
    unlabeled = np.setdiff1d(np.arange(40), labeled)
    permuted = labels.copy()
    rng = np.random.default_rng(1)
    permuted[unlabeled] = rng.permutation(labels[unlabeled])
    permuted[unlabeled[:4]] = (permuted[unlabeled[:4]] + 1) % 3  # and change some outright
    assert (permuted[unlabeled] != labels[unlabeled]).any()
    first = _one_al_round(depth, valid, Oracle(labels), labeled, seed=0)
    second = _one_al_round(depth, valid, Oracle(permuted), labeled, seed=0)
    assert first == second
    for picks in first.values():
        assert len(picks) == 5 and not set(picks) & set(labeled.tolist())

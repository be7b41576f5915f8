"""The validation split carved from the training pool for tuning."""

import numpy as np
import pytest

from spl_al.data import validation_split
from spl_al.data.validation import VALIDATION_FRACTION, VALIDATION_SEED


def _pool():
    """A dataset of 200 samples in 3 unequal classes with a 30% test split."""
    rng = np.random.default_rng(7)
    labels = np.repeat([0, 1, 2], [100, 60, 40])[rng.permutation(200)]
    split = np.where(rng.random(200) < 0.3, "test", "train")
    return labels, np.flatnonzero(split == "train"), np.flatnonzero(split == "test")


def test_validation_split_is_a_seeded_partition_of_the_training_pool():
    labels, train, test = _pool()
    fit, val = validation_split(train, 0.25, seed=3, labels=labels[train])
    assert np.array_equal(np.sort(np.r_[fit, val]), train)  # a partition of the pool ...
    assert not np.intersect1d(fit, val).size
    assert not np.intersect1d(np.r_[fit, val], test).size  # ... never the test split
    assert np.all(np.diff(fit) > 0) and np.all(np.diff(val) > 0)
    again = validation_split(train, 0.25, seed=3, labels=labels[train])
    assert np.array_equal(again[0], fit) and np.array_equal(again[1], val)
    other = validation_split(train, 0.25, seed=4, labels=labels[train])[1]
    assert not np.array_equal(other, val)
    # the draw does not depend on how the pool is ordered
    shuffled = validation_split(train[::-1], 0.25, seed=3, labels=labels[train][::-1])
    assert np.array_equal(shuffled[1], val)
    assert VALIDATION_SEED >= 0 and 0 < VALIDATION_FRACTION < 1


def test_validation_split_is_stratified_by_class():
    labels, train, _ = _pool()
    _, val = validation_split(train, 0.25, seed=0, labels=labels[train])
    for c in (0, 1, 2):
        n_c = np.sum(labels[train] == c)
        assert np.sum(labels[val] == c) == round(0.25 * n_c)
    _, flat = validation_split(train, 0.25, seed=0)  # no labels: the whole pool
    assert len(flat) == round(0.25 * len(train))


def test_validation_split_refuses_bad_arguments():
    train = np.arange(10)
    for fraction in (0.0, 1.0, -0.1):
        with pytest.raises(ValueError, match="fraction must be in"):
            validation_split(train, fraction, 0)
    with pytest.raises(ValueError, match="labels must have shape"):
        validation_split(train, 0.2, 0, labels=np.zeros(9))
    with pytest.raises(ValueError, match="must not repeat"):
        validation_split([1, 1, 2], 0.2, 0)
    with pytest.raises(ValueError, match="empty"):
        validation_split([1, 2], 0.1, 0)
    with pytest.raises(ValueError, match="seed must be"):
        validation_split(train, 0.2, -1)

"""Labeled and unlabeled pools, the simulated oracle, and the round-0 labeled set.

The pool knows indices only; the oracle alone holds labels and hands out those of
the indices it is asked about. Strategies receive neither (they get
``StrategyInputs``), so they cannot see a label of an unlabeled group.
Numpy only: a selection step that imports this does not pay for torch.
"""

from __future__ import annotations

import numpy as np

from spl_al.atomic import read_json
from spl_al.seeding import round0_rng


def _as_indices(name: str, indices, n: int) -> np.ndarray:
    a = np.asarray(indices)
    if a.size == 0:
        return np.zeros(0, dtype=np.int64)
    if a.ndim != 1 or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name} must be a 1-D array of integer indices, got {a.dtype} {a.shape}.")
    if a.min() < 0 or a.max() >= n:
        raise ValueError(f"{name} must lie in [0, {n}), got values from {a.min()} to {a.max()}.")
    if len(np.unique(a)) != len(a):
        raise ValueError(f"{name} holds duplicate indices.")
    return a.astype(np.int64)


def initial_labeled_set(
    n_train: int, size: int, seed: int, *, labels=None, stratified: bool = False
) -> np.ndarray:
    """The round-0 labeled set of a seed: sorted indices, the same for every method.

    It depends only on (n_train, size, seed, and labels when stratified), never on the
    method, which makes comparisons between methods paired.

    Args:
        n_train: number of training groups N.
        size: how many to label (0 <= size <= N).
        seed: the run's seed.
        labels: (N,) class indices, needed only when ``stratified``.
        stratified: spread the set over classes as evenly as possible (counts differ
            by at most one, classes short of members give theirs to the others);
            otherwise uniform without replacement.
    """
    if int(n_train) != n_train or n_train < 0:
        raise ValueError(f"n_train must be an integer >= 0, got {n_train!r}.")
    if int(size) != size or not 0 <= size <= n_train:
        raise ValueError(f"size must be an integer in [0, {n_train}], got {size!r}.")
    rng = round0_rng(seed)
    if not stratified:
        return np.sort(rng.choice(int(n_train), size=int(size), replace=False)).astype(np.int64)
    if labels is None:
        raise ValueError("labels are required when stratified is true.")
    y = np.asarray(labels)
    if y.shape != (n_train,):
        raise ValueError(f"labels must have shape ({n_train},), got {y.shape}.")
    classes, y_code = np.unique(y, return_inverse=True)
    order = rng.permutation(n_train)  # random order within each class ...
    rank = np.empty(n_train, dtype=np.int64)
    sorted_by_class = order[np.argsort(y_code[order], kind="stable")]
    starts = np.searchsorted(y_code[sorted_by_class], np.arange(len(classes)))
    rank[sorted_by_class] = np.arange(n_train) - starts[y_code[sorted_by_class]]
    class_turn = rng.permutation(len(classes))  # ... and a random class order per round
    chosen = np.lexsort((class_turn[y_code], rank))[: int(size)]
    return np.sort(chosen).astype(np.int64)


class Pool:
    """Which training groups are labeled; everything else is unlabeled.

    Args:
        n_train: number of training groups N.
        labeled: the indices labeled so far (e.g. ``initial_labeled_set``).
    """

    def __init__(self, n_train: int, labeled=()) -> None:
        if int(n_train) != n_train or n_train < 0:
            raise ValueError(f"n_train must be an integer >= 0, got {n_train!r}.")
        self.n_train = int(n_train)
        self._mask = np.zeros(self.n_train, dtype=bool)
        self._order = np.zeros(0, dtype=np.int64)
        self.add(labeled)

    def add(self, indices) -> None:
        """Label ``indices``; refuses duplicates, out-of-range and already labeled ones."""
        idx = _as_indices("indices", indices, self.n_train)
        already = idx[self._mask[idx]]
        if already.size:
            raise ValueError(f"indices {already[:10].tolist()} are already labeled.")
        self._mask[idx] = True
        self._order = np.concatenate([self._order, idx])

    @property
    def labeled_idx(self) -> np.ndarray:
        """Labeled indices in the order they were added (a copy)."""
        return self._order.copy()

    @property
    def unlabeled_idx(self) -> np.ndarray:
        """Unlabeled indices, ascending."""
        return np.flatnonzero(~self._mask).astype(np.int64)

    @property
    def labeled_mask(self) -> np.ndarray:
        """(n_train,) bool, True at labeled pool indices (a copy)."""
        return self._mask.copy()

    @property
    def n_labeled(self) -> int:
        """Number of labeled training samples."""
        return len(self._order)

    @property
    def n_unlabeled(self) -> int:
        """Number of training samples not yet labeled."""
        return self.n_train - self.n_labeled


class Oracle:
    """The simulated annotator: holds every training label, reveals only what is queried.

    Args:
        labels: (N,) class indices or (N, H, W) masks of the training groups (a
            group's variants share its label, so one label per group).
    """

    def __init__(self, labels) -> None:
        self._labels = np.array(labels, copy=True)
        self._labels.setflags(write=False)
        if self._labels.ndim < 1:
            raise ValueError("labels must have one entry per training group.")
        self._queried = np.zeros(len(self._labels), dtype=bool)

    @property
    def n_train(self) -> int:
        """Number of training samples in the pool."""
        return len(self._labels)

    def query(self, indices) -> np.ndarray:
        """Labels (a copy) of the groups ``indices``, in that order; they count as queried."""
        idx = _as_indices("indices", indices, self.n_train)
        self._queried[idx] = True
        return self._labels[idx].copy()

    @property
    def queried_idx(self) -> np.ndarray:
        """Every index whose label has been revealed so far, ascending."""
        return np.flatnonzero(self._queried).astype(np.int64)


def read_labeled(path) -> np.ndarray:
    """Training-split indices of a labeled set file (``labeled.json``: the round-0 set
    or a query's result, its ``pool_indices``)."""
    record = read_json(path)
    if "pool_indices" not in record:
        raise ValueError(f"{path}: not a labeled set (no 'pool_indices').")
    return np.asarray(record["pool_indices"], dtype=np.int64)

"""What a strategy may know about the pool: ``StrategyInputs``, and the names of its parts.

A strategy declares ``needs``, a set of names from ``NEEDS``; the scoring step
(``spl_al.scoring.compute_inputs``) computes exactly those parts from a model and
the images. Nothing here holds a label: the container has no field for one, so a
strategy cannot see the oracle's answers for unlabeled groups (nor ask for them).

All per-group arrays have one row per entry of ``unlabeled_idx`` (same order).
Segmentation keeps memory bounded by reducing over pixels while scoring: per-pixel
probabilities are never stored, only the per-group quantities below (exact means
over the observed image's valid pixels) and pixel-averaged features.

This module imports numpy only, so a selection step needs neither torch nor sklearn.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write

# need name -> the StrategyInputs fields it fills
NEEDS: dict[str, tuple[str, ...]] = {
    # mean over valid units of the observed image's predictive entropy, (n,)
    "entropy": ("entropy",),
    # mean over valid units of the observed image's top1 - top2 probability gap, (n,)
    "margin": ("margin",),
    # DUIS on all M+1 images: gamma (margin of the mean prediction) and d (mean KL to it)
    "margin_inconsistency": ("gamma", "inconsistency"),
    # penultimate features of the observed image, (n, d); pixel-averaged for segmentation
    "features": ("features",),
    # features averaged over the group's M+1 images, (n, d)
    "group_features": ("group_features",),
    # features of the labeled groups' observed images, (n_labeled, d)
    "labeled_features": ("labeled_features",),
    # BADGE's last-layer gradient embedding under the argmax label: rank-one factors
    # grad_q = p - onehot (n, C) and grad_h = features (n, d) for classification, or the
    # dense pixel-averaged embedding grad_embedding (n, C * d) for segmentation
    "grad_embedding": ("grad_q", "grad_h", "grad_embedding"),
    # classification: the model's last linear layer, logits = features @ W.T + b, in the
    # units of ``features``: W (C, d), b (C,); a class the model cannot predict has b = -inf;
    # and p, the dropout its input was trained with (0: none), a 0-d array
    "head": ("head_weight", "head_bias", "head_dropout"),
}
# needs that require a forward pass over every image of a group, not just the observed one
GROUP_NEEDS = frozenset({"margin_inconsistency", "group_features"})
ARRAY_FIELDS = tuple(dict.fromkeys(f for fs in NEEDS.values() for f in fs))
# fields whose rows are not one per unlabeled group: name -> (ndim, rows)
OTHER_ROWS = {
    "labeled_features": (2, "labeled"),
    "head_weight": (2, None),
    "head_bias": (1, None),
    "head_dropout": (0, None),
}


def check_needs(needs) -> frozenset[str]:
    """The set of need names, or a ValueError naming the unknown ones."""
    needs = frozenset(needs)
    unknown = sorted(needs - set(NEEDS))
    if unknown:
        raise ValueError(f"unknown needs {unknown}; expected some of {sorted(NEEDS)}.")
    return needs


def as_index_array(name: str, values) -> np.ndarray:
    """A 1-D int64 array of distinct non-negative indices, or a ValueError naming ``name``."""
    a = np.asarray(values)
    if a.size == 0:
        return np.zeros(0, dtype=np.int64)
    if a.ndim != 1 or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name} must be a 1-D array of integer indices, got {a.dtype} {a.shape}.")
    if (a < 0).any():
        raise ValueError(f"{name} must hold non-negative indices.")
    if len(np.unique(a)) != len(a):
        raise ValueError(f"{name} holds duplicate indices.")
    return a.astype(np.int64)


@dataclass
class StrategyInputs:
    """Model outputs a strategy may use, for the unlabeled groups (and labeled features).

    Attributes:
        unlabeled_idx: (n,) training-set indices of the unlabeled groups a strategy may pick.
        labeled_idx: (n_labeled,) training-set indices of the labeled groups.
        entropy, margin, gamma, inconsistency: (n,) per-group scores (see ``NEEDS``).
        features, group_features: (n, d); labeled_features: (n_labeled, d).
        grad_q: (n, C), grad_h: (n, d), grad_embedding: (n, C * d): BADGE embeddings.
        head_weight: (C, d), head_bias: (C,): the classifier's last linear layer;
        head_dropout: () the dropout rate its input was trained with (0: none).
    """

    unlabeled_idx: np.ndarray
    labeled_idx: np.ndarray
    entropy: np.ndarray | None = None
    margin: np.ndarray | None = None
    gamma: np.ndarray | None = None
    inconsistency: np.ndarray | None = None
    features: np.ndarray | None = None
    group_features: np.ndarray | None = None
    labeled_features: np.ndarray | None = None
    grad_q: np.ndarray | None = None
    grad_h: np.ndarray | None = None
    grad_embedding: np.ndarray | None = None
    head_weight: np.ndarray | None = None
    head_bias: np.ndarray | None = None
    head_dropout: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.unlabeled_idx = as_index_array("unlabeled_idx", self.unlabeled_idx)
        self.labeled_idx = as_index_array("labeled_idx", self.labeled_idx)
        if np.intersect1d(self.unlabeled_idx, self.labeled_idx).size:
            raise ValueError("unlabeled_idx and labeled_idx overlap.")
        n, n_lab = len(self.unlabeled_idx), len(self.labeled_idx)
        for name in ARRAY_FIELDS:
            value = getattr(self, name)
            if value is None:
                continue
            value = np.asarray(value)
            ndim, rows = OTHER_ROWS.get(name, (2, n))
            if name in ("entropy", "margin", "gamma", "inconsistency"):
                ndim = 1
            rows = n_lab if rows == "labeled" else rows
            if value.ndim != ndim or (rows is not None and value.shape[0] != rows):
                want = f"{ndim}-D with {rows} rows" if rows is not None else f"{ndim}-D"
                raise ValueError(f"{name} must be {want}, got shape {value.shape}.")
            setattr(self, name, value)
        if self.head_weight is not None and (
            self.head_bias is None or self.head_bias.shape != self.head_weight.shape[:1]
        ):
            raise ValueError(
                f"head_bias must be ({len(self.head_weight)},) beside head_weight "
                f"{self.head_weight.shape}."
            )

    def has(self, need: str) -> bool:
        """Whether the parts of ``need`` are present (either BADGE form counts)."""
        if need == "grad_embedding":
            return self.grad_embedding is not None or (
                self.grad_q is not None and self.grad_h is not None
            )
        return all(getattr(self, f) is not None for f in NEEDS[need])

    def require(self, needs) -> None:
        """Raise ValueError naming every need in ``needs`` that these inputs lack."""
        missing = sorted(nd for nd in check_needs(needs) if not self.has(nd))
        if missing:
            raise ValueError(f"strategy inputs lack {missing}; compute them with these needs.")

    def save(self, path: str | os.PathLike) -> None:
        """Write every present array to an .npz file atomically (``spl_al.atomic``)."""
        arrays = {f.name: getattr(self, f.name) for f in fields(self)}
        arrays = {k: v for k, v in arrays.items() if v is not None}

        def write(tmp: Path) -> None:
            with open(tmp, "wb") as fh:  # (a file object: np.savez would add ".npz")
                np.savez(fh, **arrays)

        atomic_write(path, write)

    @classmethod
    def load(cls, path: str | os.PathLike) -> StrategyInputs:
        """Read inputs written by ``save``."""
        known = {f.name for f in fields(cls)}
        with np.load(path, allow_pickle=False) as data:
            unknown = sorted(set(data.files) - known)
            if unknown or "unlabeled_idx" not in data.files:
                raise ValueError(
                    f"{path} is not a StrategyInputs file (keys {sorted(data.files)})."
                )
            return cls(**{k: data[k] for k in data.files})

    @property
    def n_unlabeled(self) -> int:
        """Number of unlabeled pool samples the strategy chooses from."""
        return len(self.unlabeled_idx)

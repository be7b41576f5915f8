"""DropQuery (Gupte, Aklilu, Nirschl, Yeung-Levy, "Revisiting Active Learning in the Era
of Vision Foundation Models", TMLR 2024), as its reference code
(github.com/sanketx/AL-foundation-models, ``query_strategies/dropout.py``) runs it.

DUIS's closest generic twin: candidates whose predictions disagree under perturbation,
then k-means diversity among them. DUIS perturbs the photon conditions (its SIV
variants); DropQuery perturbs the features with dropout, at the rate its classifier
was trained with (the reference's classifier trains and queries at ``dropout_p``):

1. y* = argmax(W f + b), the model's prediction from the features f of the observed
   image (the classifier's input: the embedding in the embedding framework, the CNN's
   penultimate features in the supervised one) through its last linear layer (W, b).
2. M = ``passes`` (3) predictions y_m = argmax(W (f * mask_m / (1 - p)) + b), each
   mask_m keeping every feature with probability 1 - p, p the dropout the classifier's
   input was trained with (``StrategyInputs.head_dropout``: the supervised CNN's
   ``dropout``, 0.5 by default; the embedding framework's ``linear_probe.DropoutHead``,
   0.75 as the reference's), inverted dropout as torch's ``nn.Dropout``.
3. Candidates: the samples whose prediction changes in more than half of the passes,
   #{m : y_m != y*} > M / 2.
4. k-means on the candidates' standardised features into B clusters (B the batch):
   each feature centred and scaled by the labeled groups' mean and standard deviation
   (sqrt(var + 1e-5)), as the reference clusters its classifier's BatchNorm output
   (statistics of its training set); the pick of each cluster is the candidate
   closest to its centre.

When there are fewer candidates than B, the candidates are the B samples with the most
changed passes (scikit-activeml's rule; ties at random), and the record says how
many passed the rule. scikit-activeml's ``DropQuery`` needs a classifier the adapter
does not give (a strategy gets features, never a model to refit) and its code runs 5
passes while its docstring says 3; this is the reference's.
"""

from __future__ import annotations

import numpy as np

from spl_al.strategies.base import Strategy, register
from spl_al.strategies.distances import centred, row_mean, sq_distances
from spl_al.strategies.inputs import StrategyInputs
from spl_al.strategies.kmeans import kmeans


def dropout_disagreements(
    features: np.ndarray,
    weight: np.ndarray,
    bias: np.ndarray,
    *,
    passes: int,
    dropout: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """#{m : argmax(W (f * mask_m / (1 - p)) + b) != argmax(W f + b)} per row, (n,).

    Args:
        features: (n, d) f; weight: (C, d) W; bias: (C,) b (-inf for a class the model
            cannot predict).
    """
    f = np.asarray(features, dtype=np.float64)
    w = np.asarray(weight, dtype=np.float64)
    b = np.asarray(bias, dtype=np.float64)
    y_star = np.argmax(f @ w.T + b, axis=1)
    changed = np.zeros(len(f), dtype=np.int64)
    for _ in range(int(passes)):
        keep = rng.random(f.shape) >= dropout
        changed += np.argmax((f * keep / (1.0 - dropout)) @ w.T + b, axis=1) != y_star
    return changed


def standardised(features: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """(features - mean) / sqrt(var + 1e-5) per column, mean and var of ``reference``
    (n_ref, d) (the labeled groups' features: a BatchNorm's training statistics), as
    float32, (n, d)."""
    ref = np.asarray(reference, dtype=np.float64)
    if len(ref) == 0:
        raise ValueError("dropquery: no labeled features to standardise by.")
    scale = np.sqrt(ref.var(axis=0) + 1e-5)
    return ((np.asarray(features, dtype=np.float64) - ref.mean(axis=0)) / scale).astype(np.float32)


@register
class DropQueryStrategy(Strategy):
    """Dropout-disagreement candidates, then one pick per k-means cluster (module docstring).

    Args:
        passes: M, dropout passes (the paper's 3).
        dropout: p, the share of features each pass drops, in (0, 1); None (the
            reference's way): the dropout the classifier's input was trained with.
    """

    name = "dropquery"
    needs = frozenset({"features", "labeled_features", "head"})

    def __init__(self, passes: int = 3, dropout: float | None = None):
        if isinstance(passes, bool) or not isinstance(passes, int | np.integer) or passes < 1:
            raise ValueError(f"dropquery: passes must be an integer >= 1, got {passes!r}.")
        number = isinstance(dropout, int | float) and not isinstance(dropout, bool)
        if dropout is not None and (not number or not 0 < dropout < 1):
            raise ValueError(
                f"dropquery: dropout must lie in (0, 1), or be null (the classifier's own), "
                f"got {dropout!r}."
            )
        self.passes = int(passes)
        self.dropout = None if dropout is None else float(dropout)

    def params(self) -> dict:
        """The strategy's parameters, as recorded with its results."""
        return {"passes": self.passes, "dropout": self.dropout}

    def _rate(self, inputs: StrategyInputs) -> float:
        """The dropout of the passes: ``dropout``, else the classifier's own."""
        if self.dropout is not None:
            return self.dropout
        trained = float(inputs.head_dropout)
        if not 0 < trained < 1:
            raise ValueError(
                "dropquery: the classifier was trained without dropout, so there is no "
                "dropout to query at; train it with dropout (train.model.dropout) or give "
                "the strategy's params.dropout."
            )
        return trained

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        feats = np.asarray(inputs.features, dtype=np.float32)
        dropout = self._rate(inputs)
        changed = dropout_disagreements(
            feats,
            inputs.head_weight,
            inputs.head_bias,
            passes=self.passes,
            dropout=dropout,
            rng=rng,
        )
        passed = np.flatnonzero(2 * changed > self.passes)
        if len(passed) >= k:
            cand = passed
        else:  # too few: the k most changed (ties at random)
            cand = np.lexsort((rng.permutation(len(changed)), -changed))[:k]
        self.decision = {"candidates": len(passed), "passes": self.passes, "dropout": dropout}
        if len(passed) < k:
            self.decision["filled_by_changes"] = int(k - len(passed))
        if len(cand) == k:
            return cand.astype(np.int64)
        feats = standardised(feats[cand], inputs.labeled_features)
        centres = kmeans(feats, k, rng=rng).astype(np.float32)
        mean = row_mean(feats)
        x = centred(feats, mean)
        d2 = sq_distances(x, np.einsum("ij,ij->i", x, x), centred(centres, mean))
        picks: list[int] = []
        for j in range(k):  # the unpicked candidate closest to each centre
            order = np.argsort(d2[:, j], kind="stable")
            picks.append(int(next(i for i in order if i not in picks)))
        return cand[np.asarray(picks, dtype=np.int64)]

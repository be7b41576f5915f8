"""The embedding framework's model: a linear classifier on frozen embeddings, and the
strategy inputs it gives.

In the embedding framework (TypiClust's second framework, Hacohen et al., ICML 2022)
a round fits multinomial logistic regression on the frozen self-supervised
embeddings of the labeled groups (``spl_al.training.contrastive``) instead of
training a network. Every strategy then sees those embeddings as its features and
this classifier's probabilities as its predictions, through the same
``StrategyInputs`` and the same scoring arithmetic as the supervised framework
(``spl_al.strategies.scores.scores_from_outputs``): BADGE's gradient embedding of a linear
classifier is exactly (p - onehot(argmax p)) x embedding, DUIS's inconsistency is
the classifier's on the variants' embeddings.

Everything here is float64 numpy and scikit-learn: no precision setting reaches it.
"""

from __future__ import annotations

import warnings

import numpy as np

from spl_al.strategies.inputs import GROUP_NEEDS, StrategyInputs, check_needs
from spl_al.strategies.scores import scores_from_outputs

DEFAULT_C = 1.0
# L-BFGS's tolerance: 1e-3 matches 1e-4's validation accuracy within 0.3 points on
# real_cls at 20-80 labels, in a quarter of the time (docs/benchmarks.md#embedding-framework)
TOL = 1e-3


class LinearProbe:
    """Multinomial logistic regression on standardised embeddings.

    Args:
        n_classes: C; probabilities always have C columns (a class without a labeled
            example gets probability 0).
        c: inverse L2 strength (scikit-learn's ``C``), chosen on the validation split
            (``python -m spl_al.bench probe``).
        tol: L-BFGS's stopping tolerance.
    """

    def __init__(self, n_classes: int, c: float = DEFAULT_C, *, tol: float = TOL) -> None:
        self.n_classes = int(n_classes)
        self.c = float(c)
        self.tol = float(tol)
        self._model = None
        self._classes = None
        self._mean = self._scale = None

    def fit(self, x, y) -> LinearProbe:
        """Fit on embeddings ``x`` (n, d) with classes ``y`` (n,) in 0..C-1."""
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.linear_model import LogisticRegression

        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y).astype(np.int64)
        if x.ndim != 2 or y.shape != (len(x),):
            raise ValueError(f"x must be (n, d) and y (n,), got {x.shape} and {y.shape}.")
        self._mean = x.mean(axis=0)
        self._scale = x.std(axis=0) + 1e-6
        self._classes = np.unique(y)
        if len(self._classes) == 1:  # one class labeled: it gets every probability
            self._model = None
            return self
        self._model = LogisticRegression(C=self.c, max_iter=500, tol=self.tol)
        with warnings.catch_warnings():
            # a few labels are often separable: lbfgs stops at max_iter, still a fine fit
            warnings.simplefilter("ignore", ConvergenceWarning)
            self._model.fit((x - self._mean) / self._scale, y)
        return self

    def head(self) -> tuple[np.ndarray, np.ndarray]:
        """(W (C, d), b (C,)) with softmax(x @ W.T + b) = ``predict_proba(x)`` on raw
        embeddings x: the standardisation folded into the weights, so that a strategy
        that perturbs the classifier's input (DropQuery's dropout) perturbs the
        embedding itself. A class without a labeled example gets b = -inf."""
        if self._classes is None:
            raise ValueError("LinearProbe.head before fit.")
        d = len(self._mean)
        weight = np.zeros((self.n_classes, d))
        bias = np.full(self.n_classes, -np.inf)
        if self._model is None:
            bias[self._classes[0]] = 0.0
            return weight, bias
        coef, intercept = self._model.coef_, self._model.intercept_
        if len(self._classes) == 2:  # scikit-learn keeps one row: logit(1) - logit(0)
            coef = np.vstack([np.zeros(d), coef[0]])
            intercept = np.array([0.0, intercept[0]])
        w = coef / self._scale
        weight[self._classes] = w
        bias[self._classes] = intercept - w @ self._mean
        return weight, bias

    def predict_proba(self, x) -> np.ndarray:
        """(n, C) class probabilities of embeddings ``x`` (n, d)."""
        if self._classes is None:
            raise ValueError("LinearProbe.predict_proba before fit.")
        x = np.asarray(x, dtype=np.float64)
        out = np.zeros((len(x), self.n_classes))
        if self._model is None:
            out[:, self._classes[0]] = 1.0
            return out
        out[:, self._classes] = self._model.predict_proba((x - self._mean) / self._scale)
        return out


def probe_inputs(
    probe: LinearProbe,
    embeddings: np.ndarray,
    needs,
    *,
    unlabeled_idx,
    labeled_idx,
    n_images: int,
) -> StrategyInputs:
    """What a strategy with ``needs`` selects from, in the embedding framework.

    Args:
        probe: the round's fitted ``LinearProbe``.
        embeddings: (N, G, d) embeddings of every training group's images (observed
            first, then its variants).
        needs: names from ``spl_al.strategies.inputs.NEEDS``.
        unlabeled_idx, labeled_idx: disjoint training-set indices.
        n_images: images per group the group needs (DUIS's margin and inconsistency,
            group features) are computed on: 1 + the method's M.

    Returns:
        ``StrategyInputs`` with exactly the needed parts; features are embeddings.
    """
    needs = check_needs(needs)
    unl = np.asarray(unlabeled_idx, dtype=np.int64)
    lab = np.asarray(labeled_idx, dtype=np.int64)
    g = int(n_images) if needs & GROUP_NEEDS else 1
    feats = embeddings[unl, :g]  # (n, G, d)
    b, _, d = feats.shape
    probs = probe.predict_proba(feats.reshape(b * g, d)).reshape(b, g, 1, -1)
    arrays = dict(
        scores_from_outputs(needs - {"labeled_features", "head"}, "classification", probs, feats)
    )
    if "labeled_features" in needs:
        arrays["labeled_features"] = embeddings[lab, 0]
    if "head" in needs:
        arrays["head_weight"], arrays["head_bias"] = probe.head()
    arrays = {
        k: v.astype(np.float32) if np.ndim(v) == 2 else np.asarray(v, dtype=np.float64)
        for k, v in arrays.items()
    }
    return StrategyInputs(unlabeled_idx=unl, labeled_idx=lab, **arrays)


def embedding_features(inputs: StrategyInputs, embeddings: np.ndarray, *, n_images: int):
    """``inputs`` with its features taken from the self-supervised embedding: what a
    feature-only strategy with ``features: embedding`` selects on in the supervised
    framework (as TypiClust and ProbCover select in their papers).

    ``embeddings``: (N, G, d) of every training group's images; ``n_images``: images
    per group of ``group_features`` (1 + the method's M). Features, group features and
    labeled features present in ``inputs`` are replaced; scores stay the model's.
    """
    n_train = len(inputs.unlabeled_idx) + len(inputs.labeled_idx)
    if len(embeddings) != n_train:
        raise ValueError(
            f"the embeddings hold {len(embeddings)} training groups, the round's pool "
            f"{n_train}; train the encoder again for this dataset (remove it and rerun)."
        )
    unl, lab = inputs.unlabeled_idx, inputs.labeled_idx
    swapped = {
        "features": lambda: embeddings[unl, 0],
        "group_features": lambda: embeddings[unl, : int(n_images)].mean(axis=1),
        "labeled_features": lambda: embeddings[lab, 0],
    }
    for name, value in swapped.items():
        if getattr(inputs, name) is not None:
            setattr(inputs, name, np.asarray(value(), dtype=np.float32))
    return inputs

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

DropQuery perturbs a classifier's input with the dropout that classifier trained with.
The probe trains with none, so DropQuery's query reads a head of its own,
``DropoutHead``: the reference's classifier (dropout on the embedding, then
standardisation and a linear layer), fitted on the same labeled images as the probe,
which stays the model every method is measured by.

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


HEAD_DROPOUT = 0.75
"""DropQuery's dropout p: its reference classifier's ``dropout_p``
(github.com/sanketx/AL-foundation-models, ``conf/al_train.yaml``)."""


class DropoutHead:
    """A linear classifier trained under input dropout, as DropQuery's reference code
    trains its classifier (``classifiers/linear_classifier.py``): logits =
    W ((x * m / (1 - p) - mu) / s) + b, m ~ Bernoulli(1 - p) per feature during training,
    mu and s the training inputs' mean and standard deviation (sqrt(var + 1e-5), the
    statistics its BatchNorm1d(affine=False) gathers), cross-entropy, AdamW (lr 1e-2,
    weight decay 1e-2, full batch, float32), at most 400 epochs, stopped when the
    epoch's loss has not fallen by 1e-3 for 20 epochs (its EarlyStopping).

    Args:
        n_classes: C; a class without a labeled example keeps its (trained-down) logit.
        dropout: p in [0, 1).
    """

    def __init__(
        self,
        n_classes: int,
        dropout: float = HEAD_DROPOUT,
        *,
        lr: float = 1e-2,
        weight_decay: float = 1e-2,
        max_epochs: int = 400,
        patience: int = 20,
        min_delta: float = 1e-3,
    ) -> None:
        if not 0 <= float(dropout) < 1:
            raise ValueError(f"DropoutHead: dropout must lie in [0, 1), got {dropout!r}.")
        self.n_classes = int(n_classes)
        self.dropout = float(dropout)
        self.lr, self.weight_decay = float(lr), float(weight_decay)
        self.max_epochs, self.patience, self.min_delta = int(max_epochs), int(patience), min_delta
        self._fitted = None
        self.epochs = 0

    def fit(self, x, y, rng: np.random.Generator) -> DropoutHead:
        """Fit on embeddings ``x`` (n, d) with classes ``y`` (n,) in 0..C-1; ``rng``
        draws the initial weights (torch's ``nn.Linear`` rule) and every dropout mask."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y).astype(np.int64)
        if x.ndim != 2 or y.shape != (len(x),):
            raise ValueError(f"x must be (n, d) and y (n,), got {x.shape} and {y.shape}.")
        n, d = x.shape
        mu, scale = x.mean(axis=0), np.sqrt(x.var(axis=0) + 1e-5)
        bound = 1.0 / np.sqrt(d)
        # float32 throughout the loop, as the reference's own training (3x faster here)
        f32 = np.float32
        params = [
            rng.uniform(-bound, bound, (self.n_classes, d)).astype(f32),
            rng.uniform(-bound, bound, self.n_classes).astype(f32),
        ]
        moments = [[np.zeros_like(p), np.zeros_like(p)] for p in params]
        onehot = np.eye(self.n_classes, dtype=f32)[y]
        # z = (x * mask / (1 - p) - mu) / s = mask * xs - c, with xs and c computed once
        xs = (x / ((1.0 - self.dropout) * scale)).astype(f32)
        c = (mu / scale).astype(f32)
        z = np.empty_like(xs)
        rows = np.arange(n)
        best, waited = np.inf, 0
        b1, b2, eps = 0.9, 0.999, 1e-8  # torch.optim.AdamW's defaults
        for epoch in range(1, self.max_epochs + 1):
            np.multiply(xs, rng.random(xs.shape, dtype=f32) >= self.dropout, out=z)
            z -= c
            logits = z @ params[0].T + params[1]
            logits -= logits.max(axis=1, keepdims=True)
            prob = np.exp(logits)
            prob /= prob.sum(axis=1, keepdims=True)
            loss = float(-np.log(prob[rows, y] + 1e-30).mean())
            g = (prob - onehot) / n
            grads = [g.T @ z, g.sum(axis=0)]
            for p, grad, m in zip(params, grads, moments, strict=True):
                p *= 1.0 - self.lr * self.weight_decay  # decoupled weight decay
                m[0] = b1 * m[0] + (1 - b1) * grad
                m[1] = b2 * m[1] + (1 - b2) * grad**2
                step = (m[0] / (1 - b1**epoch)) / (np.sqrt(m[1] / (1 - b2**epoch)) + eps)
                p -= self.lr * step
            self.epochs = epoch
            if loss < best - self.min_delta:
                best, waited = loss, 0
            else:
                waited += 1
                if waited >= self.patience:
                    break
        params = [p.astype(np.float64) for p in params]
        self._fitted = (params[0], params[1], mu, scale)
        return self

    def head(self) -> tuple[np.ndarray, np.ndarray, float]:
        """(W (C, d), b (C,), p) on raw embeddings: softmax(x @ W.T + b) is the head's
        prediction without dropout, the standardisation folded into W and b so that
        dropout on the raw embedding is what it trained with."""
        if self._fitted is None:
            raise ValueError("DropoutHead.head before fit.")
        weight, bias, mu, scale = self._fitted
        w = weight / scale
        return w, bias - w @ mu, self.dropout


HEAD_EXAMPLES = 5000
"""Examples ``dropout_head`` fits on at most: a segmentation round labels ~10,000 pixels,
whose full-batch fit would cost seconds; classification's rounds fit fewer."""


def dropout_head(x, y, n_classes: int, rng: np.random.Generator) -> DropoutHead:
    """DropQuery's head fitted on a round's examples ``x`` (n, d), ``y`` (n,): at most
    ``HEAD_EXAMPLES`` of them, a draw of ``rng`` (which then draws the head's weights
    and masks)."""
    if len(y) > HEAD_EXAMPLES:
        pick = np.sort(rng.choice(len(y), HEAD_EXAMPLES, replace=False))
        x, y = x[pick], y[pick]
    return DropoutHead(n_classes).fit(x, y, rng)


def probe_inputs(
    probe: LinearProbe,
    embeddings: np.ndarray,
    needs,
    *,
    unlabeled_idx,
    labeled_idx,
    n_images: int,
    head: tuple | None = None,
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
        head: (W, b, p) the "head" need reads (``DropoutHead.head``); needed with it.

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
        if head is None:
            raise ValueError("probe_inputs: the 'head' need takes a head (DropoutHead.head()).")
        arrays["head_weight"], arrays["head_bias"], arrays["head_dropout"] = head
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

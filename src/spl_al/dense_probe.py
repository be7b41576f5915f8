"""The dense embedding framework's model: a per-pixel (per-point) linear classifier on
frozen dense features.

Segmentation's counterpart of ``spl_al.linear_probe``: each round fits multinomial
logistic regression on the frozen per-pixel features (``spl_al.training.dense_contrastive``)
of the labeled scans' valid pixels, each class's pixels weighted n_c^-balance as the
networks weigh them (``balance`` of the training recipe: rare classes, poles and
pedestrians at ~1% of the pixels, count as much as the road in mIoU). A point cloud's
points are its scan's valid pixels, so the same classifier is the per-point one.

``dense_probe_inputs`` gives every strategy what it selects from, as
``linear_probe.probe_inputs`` does for classification: DUIS's uncertainty and
inconsistency per pixel averaged over a scan's valid pixels (the paper's units),
its diversity on the dense features pooled over the scan.

Float64 numpy and scikit-learn: no precision setting reaches it.
"""

from __future__ import annotations

import warnings

import numpy as np

from spl_al.strategies.inputs import GROUP_NEEDS, StrategyInputs, check_needs
from spl_al.strategies.scores import scores_from_outputs

DEFAULT_C = 1.0
DEFAULT_BALANCE = 0.5
MAX_FIT_PIXELS = 60_000
"""Pixels a fit reads at most (a uniform draw of the labeled ones): 6 labeled scans
already hold ~12,000; the fit stays seconds at 36."""
TOL = 1e-3


def class_weights(y: np.ndarray, n_classes: int, balance: float) -> np.ndarray:
    """(C,) weights n_c^-balance of the classes in ``y`` (absent classes 0), scaled so
    that the mean weight per unit is 1 (``training.fit.balanced_class_weights``)."""
    counts = np.bincount(y, minlength=n_classes)[:n_classes].astype(np.float64)
    w = np.where(counts > 0, np.maximum(counts, 1) ** -float(balance), 0.0)
    return w * counts.sum() / max((w * counts).sum(), 1e-12)


class DenseProbe:
    """Per-pixel multinomial logistic regression on standardised dense features.

    Args:
        n_classes: C; probabilities always have C columns (a class without a labeled
            pixel gets probability 0).
        c: inverse L2 strength (scikit-learn's ``C``).
        balance: class weighting power (0: every pixel alike).
        max_pixels: the largest number of labeled pixels a fit reads.
    """

    def __init__(
        self,
        n_classes: int,
        c: float = DEFAULT_C,
        *,
        balance: float = DEFAULT_BALANCE,
        max_pixels: int = MAX_FIT_PIXELS,
        tol: float = TOL,
    ) -> None:
        self.n_classes = int(n_classes)
        self.c, self.balance, self.tol = float(c), float(balance), float(tol)
        self.max_pixels = int(max_pixels)
        self._model = None
        self._classes = None
        self._mean = self._scale = None

    def fit(self, x, y, rng: np.random.Generator) -> DenseProbe:
        """Fit on pixel features ``x`` (n, d) with classes ``y`` (n,) in 0..C-1; ``rng``
        draws the pixels read when there are more than ``max_pixels``."""
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.linear_model import LogisticRegression

        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y).astype(np.int64)
        if x.ndim != 2 or y.shape != (len(x),):
            raise ValueError(f"x must be (n, d) and y (n,), got {x.shape} and {y.shape}.")
        if len(y) == 0:
            raise ValueError("the dense probe needs at least one labeled pixel, got none.")
        if len(y) > self.max_pixels:
            pick = np.sort(rng.choice(len(y), self.max_pixels, replace=False))
            x, y = x[pick], y[pick]
        self._mean = x.mean(axis=0)
        self._scale = x.std(axis=0) + 1e-6
        self._classes = np.unique(y)
        if len(self._classes) == 1:
            self._model = None
            return self
        weight = class_weights(y, self.n_classes, self.balance)[y]
        self._model = LogisticRegression(C=self.c, max_iter=500, tol=self.tol)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            self._model.fit((x - self._mean) / self._scale, y, sample_weight=weight)
        return self

    def predict_proba(self, x) -> np.ndarray:
        """(n, C) class probabilities of pixel features ``x`` (n, d)."""
        x = np.asarray(x, dtype=np.float64)
        out = np.zeros((len(x), self.n_classes))
        if self._model is None:
            out[:, self._classes[0]] = 1.0
            return out
        out[:, self._model.classes_] = self._model.predict_proba((x - self._mean) / self._scale)
        return out


def pooled_features(features: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Scan-level features: the mean of (n, H, W, d) dense features over the valid
    pixels of (n, H, W) ``valid`` (all pixels of a scan without any): (n, d)."""
    m = valid.reshape(len(valid), -1).astype(np.float64)
    m[m.sum(axis=1) == 0] = 1.0
    f = features.reshape(len(features), -1, features.shape[-1]).astype(np.float64)
    return np.einsum("nud,nu->nd", f, m) / m.sum(axis=1)[:, None]


def dense_probe_inputs(
    probe: DenseProbe,
    features,
    valid,
    needs,
    *,
    unlabeled_idx,
    labeled_idx,
    n_images: int,
    chunk: int = 16,
) -> StrategyInputs:
    """What a strategy with ``needs`` selects from, in the dense embedding framework.

    The probe's per-pixel probabilities are the units DUIS's margin and inconsistency
    average over a scan's valid pixels (each image's own valid pixels: a variant's
    voids are not scored); features are the dense features pooled over the observed
    scan's valid pixels, for every image of a group alike (the k-means of DUIS and the
    diversity baselines, Coreset's distances); BADGE reads the per-pixel features.

    Args:
        probe: the round's fitted ``DenseProbe``.
        features: (N, G, H, W, d) dense features of every training scan's images
            (observed first, then its variants); a memory map serves.
        valid: (N, G, H, W) bool, the pixels each image holds.
        needs: names from ``spl_al.strategies.inputs.NEEDS`` ("head" is refused: it
            reads a classifier's last layer).
        unlabeled_idx, labeled_idx: disjoint training-set indices.
        n_images: images per group the group needs are computed on: 1 + the method's M.
        chunk: scans scored at a time (memory: chunk x G x H x W x (d + C)).

    Returns:
        ``StrategyInputs`` with exactly the needed parts.
    """
    needs = check_needs(needs)
    if "head" in needs:
        raise ValueError("a dense probe has no dropout head: DropQuery is for classification.")
    unl = np.asarray(unlabeled_idx, dtype=np.int64)
    lab = np.asarray(labeled_idx, dtype=np.int64)
    g = int(n_images) if needs & GROUP_NEEDS else 1
    scored = needs - {"labeled_features"}
    parts: dict[str, list[np.ndarray]] = {}
    for s in range(0, len(unl) if scored else 0, max(1, int(chunk))):
        idx = unl[s : s + chunk]
        f = np.asarray(features[idx, :g], dtype=np.float32)  # (b, g, H, W, d)
        v = np.asarray(valid[idx, :g], dtype=bool)
        b, _, h, w, d = f.shape
        probs = probe.predict_proba(f.reshape(-1, d)).reshape(b, g, h * w, -1)
        obs = np.repeat(v[:, :1], g, axis=1).reshape(b * g, h, w)
        pooled = pooled_features(f.reshape(b * g, h, w, d), obs).reshape(b, g, d)
        pix = f.reshape(b, g, h * w, d) if "grad_embedding" in needs else None
        for name, value in scores_from_outputs(
            scored, "segmentation", probs, pooled, pix_feats=pix, image_valid=v.reshape(b, g, -1)
        ):
            parts.setdefault(name, []).append(value)
    arrays = {name: np.concatenate(chunks) for name, chunks in parts.items()}
    if "labeled_features" in needs:
        arrays["labeled_features"] = pooled_features(
            np.asarray(features[lab, 0], dtype=np.float32), np.asarray(valid[lab, 0], dtype=bool)
        )
    arrays = {
        k: v.astype(np.float32) if np.ndim(v) == 2 else np.asarray(v, dtype=np.float64)
        for k, v in arrays.items()
    }
    return StrategyInputs(unlabeled_idx=unl, labeled_idx=lab, **arrays)

"""The dense embedding framework's model: a per-pixel (per-point) linear classifier on
frozen dense features.

Segmentation's counterpart of ``spl_al.linear_probe``: each round fits multinomial
logistic regression on the frozen per-pixel features (``spl_al.training.dense_contrastive``)
of the labeled scans' valid pixels, each class's pixels weighted n_c^-balance as the
networks weigh them (``balance`` of the training recipe: rare classes, poles and
pedestrians at ~1% of the pixels, count as much as the road in mIoU). A point cloud's
points are its scan's valid pixels, so the same classifier is the per-point one.

The probe reads the encoder's features beside ``local_depth_features``, nine
per-pixel depth statistics (range, row, local contrasts, gradients, support): alone,
the encoder's features segment a little worse than these nine, and together they add
6-9 mIoU points to them (docs/benchmarks.md#segmentation-a-dense-encoder).

``dense_probe_inputs`` gives every strategy what it selects from, as
``linear_probe.probe_inputs`` does for classification: DUIS's uncertainty and
inconsistency per unit (pixel or point) averaged over a scan's valid units (the
paper's units), its diversity on the dense features pooled over the scan, DropQuery's
dropout passes through a head on those pooled features.

Fitted in float64 (``spl_al.multinomial``: scikit-learn's objective and solver
settings), applied in float32 (the standardisation folded into the weights): no
precision setting reaches it.
"""

from __future__ import annotations

import numpy as np

from spl_al.multinomial import fit_multinomial
from spl_al.strategies.inputs import GROUP_NEEDS, StrategyInputs, check_needs
from spl_al.strategies.scores import scores_from_outputs

DEFAULT_C = 1.0
DEFAULT_BALANCE = 0.5
MAX_FIT_PIXELS = 60_000
"""Pixels a fit reads at most (a uniform draw of the labeled ones): 6 labeled scans
already hold ~12,000; the fit stays seconds at 36."""
TOL = 1e-3


def _box_mean(a: np.ndarray, k: int) -> np.ndarray:
    """Mean over a k x k window (edge-padded) of each (n, H, W) image."""
    from scipy.ndimage import uniform_filter

    return uniform_filter(a, size=(1, k, k), mode="nearest")


def local_depth_features(depth_m, valid) -> np.ndarray:
    """(n, H, W, 9) local depth features of every pixel of (n, H, W) scans: range / 50 m,
    row position, range minus its 3x3 and 7x7 means, the 3x3 standard deviation, the
    row and column gradients, the 3x3 share of valid pixels and log(1 + range). Voids
    are filled with the 7x7 mean of their valid neighbours (0 without any) first."""
    d = np.where(valid, np.nan_to_num(depth_m, nan=0.0), 0.0).astype(np.float64)
    v = valid.astype(np.float64)
    h = d.shape[1]
    fill7 = _box_mean(d, 7) / np.maximum(_box_mean(v, 7), 1e-6)
    d = np.where(valid, d, fill7)
    m3, m7 = _box_mean(d, 3), _box_mean(d, 7)
    sd3 = np.sqrt(np.maximum(_box_mean(d * d, 3) - m3 * m3, 0.0))
    gy, gx = np.gradient(d, axis=(1, 2))
    row = np.broadcast_to(np.linspace(0, 1, h)[None, :, None], d.shape)
    feats = [d / 50.0, row, d - m3, d - m7, sd3, gy, gx, _box_mean(v, 3), np.log1p(d)]
    return np.stack([np.clip(f, -50, 50) for f in feats], axis=-1)


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
        self._classes = None
        self._mean = self._scale = None
        self._weight = self._bias = None
        self._iterations = 0

    def fit(self, x, y, rng: np.random.Generator, *, start: DenseProbe | None = None) -> DenseProbe:
        """Fit on pixel features ``x`` (n, d) with classes ``y`` (n,) in 0..C-1; ``rng``
        draws the pixels read when there are more than ``max_pixels``. ``start``: a
        probe fitted before on the same features (a run's previous round), whose
        function the solver starts from when it saw the same classes (fewer iterations
        to the same optimum, within ``tol``)."""
        y = np.asarray(y).astype(np.int64)
        if np.ndim(x) != 2 or y.shape != (len(x),):
            raise ValueError(f"x must be (n, d) and y (n,), got {np.shape(x)} and {y.shape}.")
        if len(y) == 0:
            raise ValueError("the dense probe needs at least one labeled pixel, got none.")
        if len(y) > self.max_pixels:
            pick = np.sort(rng.choice(len(y), self.max_pixels, replace=False))
            x, y = x[pick], y[pick]
        x = np.asarray(x, dtype=np.float64)
        self._mean = x.mean(axis=0)
        self._scale = x.std(axis=0) + 1e-6
        self._classes, seen = np.unique(y, return_inverse=True)
        self._iterations = 0
        if len(self._classes) == 1:
            self._weight = None
            return self
        coef = None
        same = start is not None and np.array_equal(start._classes, self._classes)
        if same and start._weight is not None:
            # the previous function in this fit's standardisation: x @ W.T + b
            # = ((x - m) / s) @ (W * s).T + (b + W @ m)
            w0 = start._weight.astype(np.float64)
            coef = np.column_stack([w0 * self._scale, start._bias + w0 @ self._mean])
        weight = class_weights(y, self.n_classes, self.balance)[y]
        coef, self._iterations = fit_multinomial(
            (x - self._mean) / self._scale, seen, weight, c=self.c, tol=self.tol, coef=coef
        )
        # the standardisation folded into float32 weights:
        # ((x - m) / s) @ W.T + b = x @ (W / s).T + (b - (W / s) @ m)
        w = coef[:, :-1] / self._scale
        self._weight = w.astype(np.float32)
        self._bias = (coef[:, -1] - w @ self._mean).astype(np.float32)
        return self

    @property
    def iterations(self) -> int:
        """The solver's iterations in the last fit (0 when it had one class)."""
        return self._iterations

    def logits(self, x) -> np.ndarray:
        """(n, k) float32 logits of the k classes seen in the fit (in class order) for
        pixel features ``x`` (n, d)."""
        return np.asarray(x, dtype=np.float32) @ self._weight.T + self._bias

    def predict(self, x) -> np.ndarray:
        """(n,) the most probable class of each of pixel features ``x`` (n, d)."""
        if self._weight is None:
            return np.full(len(x), self._classes[0], dtype=np.int64)
        return self._classes[self.logits(x).argmax(axis=1)]

    def predict_proba(self, x) -> np.ndarray:
        """(n, C) float32 class probabilities of pixel features ``x`` (n, d)."""
        out = np.zeros((len(x), self.n_classes), dtype=np.float32)
        if self._weight is None:
            out[:, self._classes[0]] = 1.0
            return out
        # class-major (k, n): the reductions over k classes run down rows, ~2x faster
        z = self._weight @ np.asarray(x, dtype=np.float32).T
        z += self._bias[:, None]
        z -= z.max(axis=0)
        np.exp(z, out=z)
        z /= z.sum(axis=0)
        out[:, self._classes] = z.T
        return out


def pooled_features(features: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Scan-level features: the mean of (n, U, d) dense features (U units: pixels,
    points, or a sample of them) over the valid units of (n, U) ``valid`` (all units of
    a scan without any): (n, d) float32. (n, H, W, d) and (n, H, W) serve as well."""
    m = np.asarray(valid).reshape(len(valid), -1).astype(np.float32)
    m[m.sum(axis=1) == 0] = 1.0
    f = np.asarray(features, dtype=np.float32).reshape(len(features), -1, features.shape[-1])
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
    head: tuple | None = None,
    chunk: int = 64,
) -> StrategyInputs:
    """What a strategy with ``needs`` selects from, in the dense embedding framework.

    The probe's per-unit probabilities are what DUIS's margin and inconsistency
    average over a scan's valid units (each image's own valid units: a variant's voids
    are not scored); features are the dense features pooled over the observed scan's
    valid units, for every image of a group alike (the k-means of DUIS and the
    diversity baselines, Coreset's distances, DropQuery's passes); BADGE reads the
    per-unit features.

    Args:
        probe: the round's fitted ``DenseProbe``.
        features: (N, G, U, d) dense features of U units (pixels, points, or a fixed
            sample of them) of every training scan's images (observed first, then its
            variants), unit u the same place in every image of a group.
        valid: (N, G, U) bool, the units each image holds.
        needs: names from ``spl_al.strategies.inputs.NEEDS``.
        unlabeled_idx, labeled_idx: disjoint training-set indices.
        n_images: images per group the group needs are computed on: 1 + the method's M.
        head: (W, b, p) the "head" need reads (``linear_probe.DropoutHead.head`` fitted
            on the labeled units' features); needed with it.
        chunk: scans scored at a time (memory: chunk x G x U x (d + C)).

    Returns:
        ``StrategyInputs`` with exactly the needed parts.
    """
    needs = check_needs(needs)
    if "head" in needs and head is None:
        raise ValueError("dense_probe_inputs: the 'head' need takes a head (DropoutHead.head()).")
    unl = np.asarray(unlabeled_idx, dtype=np.int64)
    lab = np.asarray(labeled_idx, dtype=np.int64)
    g = int(n_images) if needs & GROUP_NEEDS else 1
    scored = needs - {"labeled_features", "head"}
    parts: dict[str, list[np.ndarray]] = {}
    for s in range(0, len(unl) if scored else 0, max(1, int(chunk))):
        idx = unl[s : s + chunk]
        f = np.asarray(features[idx, :g], dtype=np.float32)  # (b, g, U, d)
        v = np.asarray(valid[idx, :g], dtype=bool)
        b, _, u, d = f.shape
        probs = probe.predict_proba(f.reshape(-1, d)).reshape(b, g, u, -1)
        obs = np.repeat(v[:, :1], g, axis=1).reshape(b * g, u)
        pooled = pooled_features(f.reshape(b * g, u, d), obs).reshape(b, g, d)
        pix = f if "grad_embedding" in needs else None
        for name, value in scores_from_outputs(
            scored, "segmentation", probs, pooled, pix_feats=pix, image_valid=v
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
    if "head" in needs:
        arrays["head_weight"], arrays["head_bias"], arrays["head_dropout"] = head
    return StrategyInputs(unlabeled_idx=unl, labeled_idx=lab, **arrays)

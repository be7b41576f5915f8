"""DUIS and every registered strategy for a model spl-al does not know: ``spl_al.query``.

``query(method, predict, depth_m, valid, labeled=..., budget=...)`` returns the indices
of the ``budget`` frames the strategy ``method`` asks to label next, scoring the frames
with the user's own ``predict`` function. ``Request`` holds every option and ``run``
returns a ``Selection`` (the indices, how many frames ``predict`` saw, where the time
went).

``predict(depth_m, valid)`` takes a batch of at most ``Request.batch_size`` frames (256
by default: memory stays bounded whatever the pool), depth (B, H, W) float32 in metres
with NaN at voids and the (B, H, W) bool mask of the pixels with a return, and returns
class probabilities (B, C), or per-pixel probabilities (B, C, H, W) for segmentation,
or a tuple (probabilities, features) with features (B, D) (segmentation may give
(B, D, H, W), averaged here over the observed frame's valid pixels): numpy arrays or
CPU torch tensors.

What each strategy reads (its ``needs``, ``spl_al.strategies.inputs.NEEDS``):

- random: nothing (``predict`` is not called); entropy, margin: the probabilities of
  the frame (segmentation: means over its valid pixels).
- duis, diversity: every frame with its M SIV variants (``n_variants``, default 4),
  made by spl-al's photon engine from the frame itself
  (``spl_al.photon.synthesize_variants``) at the first M conditions of the default
  MSPPP x SBR set in ``spl_al.data.variants.spread_conditions`` order ((5, 1), (2,
  0.2), (2, 5), (10, 0.2) for M = 4); ``predict`` sees the frame and its variants
  (M + 1 times the pool). DUIS's margin and inconsistency come from their
  probabilities; its k-means reads the features averaged over the M + 1 images.
- coreset, typiclust, probcover, maxherding (and scikit-activeml ones): the features
  of the unlabeled and the labeled frames.
- badge: the gradient embedding, from the features and the probabilities.
- dropquery: the classifier's last linear layer, which a function does not expose:
  pass ``Request(head=(weight (C, D), bias (C,), dropout p))``.

**Without features** (``predict`` returns probabilities only), the k-means and the
distances of duis, diversity, coreset, typiclust, probcover and maxherding read the
class probabilities instead: (C,) per frame, for segmentation the mean of the
per-pixel probabilities over the frame's valid pixels (DUIS: averaged over the frame
and its variants). The candidate pool is then diverse in what the model predicts
rather than in what it sees. BADGE, whose embedding is the features' gradient, is
refused without features, and DropQuery without a head; a refusal is one sentence
naming what is missing and what was expected.

**Photon defaults** of DUIS's variants. ``sensor`` None: ``SensorParams.paper_real()``,
the paper's scanning sensor (12,500 bins of 80 ps: 150 m of reach; 520 ps of timing
jitter, about 8 cm of depth noise per photon); the jitter sets the depth noise of
the variants, and a frame deeper than the reach is refused (give a sensor with
more or wider bins). ``reflectance`` None: uniform, every valid pixel receives the
condition's MSPPP on average; with the frames' own reflectance (any scale) dark
pixels receive fewer photons and become voids sooner, as they would on the sensor.

``n_cand`` (DUIS, diversity): the paper's 500 when the pool allows it, else half the
unlabeled frames (the most a candidate pool may be, ``strategies.duis``); a
``params["n_cand"]`` of more than half the unlabeled frames is refused.

**Variants once per pool.** The variants depend on the frames, the seed and the photon
settings, never on the model, and making them is most of a DUIS query's time when
``predict`` is a small network (docs/benchmarks.md#query). ``make_variants`` makes them
as ``query`` would; give them to every round's ``run(Request(..., variants=...))`` and
a round spends its time in ``predict``. ``n_jobs`` makes them in that many processes
(the same numbers).

Randomness: the strategy's choices from ``seeding.acquire_rng(seed)``, frame i's
photons from ``sample_rng(seed, STREAM_VARIANT, i)``; the same seed gives the same
picks, whatever ``batch_size`` and ``n_jobs``.
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from spl_al.data.observe import condition_set
from spl_al.data.seeds import STREAM_VARIANT
from spl_al.data.variants import spread_conditions
from spl_al.photon import SensorParams, synthesize_variants
from spl_al.seeding import acquire_rng, sample_rng
from spl_al.strategies import GROUP_NEEDS, StrategyInputs, check_picks, get
from spl_al.strategies.duis import check_candidate_pool
from spl_al.strategies.inputs import as_index_array
from spl_al.strategies.scores import scores_from_outputs

DEFAULT_BATCH_SIZE = 256
"""Frames per call of ``predict``."""
DEFAULT_N_VARIANTS = 4
"""M, DUIS's variants per frame (the paper's default)."""
FEATURE_NEEDS = frozenset({"features", "group_features", "labeled_features"})
"""Needs that read features; without features from ``predict``, its probabilities."""


@dataclass
class Request:
    """Everything one query takes (``query``'s arguments, and more options).

    Attributes:
        method: a registered strategy (``spl_al.strategies.names()``).
        predict: the user's model (module docstring).
        depth_m: (N, H, W) depth of the pool in metres (read where ``valid``).
        valid: (N, H, W) bool, the pixels with a return.
        labeled: indices of the frames already labeled (never picked).
        budget: how many frames to pick, at most the unlabeled ones.
        seed: seed of every random choice (module docstring).
        params: the strategy's parameters (e.g. ``{"n_cand": 24, "alpha": 0.5}``).
        sensor, reflectance: the photon engine's inputs for SIV variants (module docstring).
        batch_size: frames per ``predict`` call (memory stays bounded by it).
        n_variants: M, SIV variants per frame (strategies that read groups).
        conditions: M (msppp, sbr) pairs, variant j at entry j; None: the default set.
        reconstruct_method: how variants are reconstructed (``spl_al.photon.reconstruct``).
        head: (weight (C, D), bias (C,), dropout p): the classifier's last linear layer on
            its features, logits = features @ weight.T + bias (dropquery only).
        variants: (N, M, H, W) depth of the frames' SIV variants, NaN at voids
            (``make_variants``); None: made here. Given, M is their second axis and
            ``n_variants``, ``conditions``, ``sensor`` and ``reflectance`` are not read.
        n_jobs: processes that make the variants (1: in this one).
    """

    method: str
    predict: Callable
    depth_m: np.ndarray
    valid: np.ndarray
    labeled: object = ()
    budget: int = 1
    seed: int = 0
    params: dict | None = None
    sensor: SensorParams | None = None
    reflectance: np.ndarray | None = None
    batch_size: int = DEFAULT_BATCH_SIZE
    n_variants: int = DEFAULT_N_VARIANTS
    conditions: list | None = None
    reconstruct_method: str = "pooled"
    head: tuple | None = None
    variants: np.ndarray | None = None
    n_jobs: int = 1


@dataclass
class Selection:
    """What ``run`` returns.

    Attributes:
        indices: (budget,) int64 distinct indices into the frames, none labeled.
        frames_predicted: frames ``predict`` was called on (variants included).
        seconds: wall seconds spent in ``predict``, in making ``variants``, in the
            strategy's ``select`` (k-means, ranking) and in ``total``.
        task: "classification" or "segmentation" ("" when ``predict`` was not called).
    """

    indices: np.ndarray
    frames_predicted: int = 0
    seconds: dict = field(default_factory=dict)
    task: str = ""


def query(
    method: str,
    predict: Callable,
    depth_m,
    valid,
    *,
    labeled,
    budget: int,
    seed: int = 0,
    params: dict | None = None,
    sensor: SensorParams | None = None,
    reflectance=None,
) -> np.ndarray:
    """The ``budget`` frames strategy ``method`` picks for labeling (module docstring).

    Args:
        method: a registered strategy: duis, random, entropy, margin, coreset, badge,
            typiclust, probcover, maxherding, dropquery (``Request.head``), diversity, or
            one an installed package registers.
        predict: ``predict(depth_m (B, H, W), valid (B, H, W))`` -> probabilities (B, C)
            or (B, C, H, W), or (probabilities, features (B, D)).
        depth_m: (N, H, W) depth in metres, NaN at voids.
        valid: (N, H, W) bool mask of the pixels with a return.
        labeled: indices of the frames already labeled.
        budget: frames to pick, 1 to the number of unlabeled frames.
        seed: the same seed gives the same picks.
        params: the strategy's parameters, e.g. ``{"n_cand": 24}``.
        sensor: the SPL timing of DUIS's variants (None: the paper's scanning sensor).
        reflectance: (N, H, W) reflectance of the frames (None: uniform).

    Returns:
        (budget,) int64 distinct indices into the frames, none of them in ``labeled``.

    Raises:
        ValueError: one sentence for bad input, a strategy whose needs ``predict``
            cannot meet, or a budget larger than the unlabeled pool.
    """
    request = Request(
        method=method,
        predict=predict,
        depth_m=depth_m,
        valid=valid,
        labeled=labeled,
        budget=budget,
        seed=seed,
        params=params,
        sensor=sensor,
        reflectance=reflectance,
    )
    return run(request).indices


def make_variants(
    depth_m,
    valid,
    *,
    seed: int = 0,
    n_variants: int = DEFAULT_N_VARIANTS,
    conditions=None,
    sensor: SensorParams | None = None,
    reflectance=None,
    reconstruct_method: str = "pooled",
    n_jobs: int = 1,
    chunk: int = DEFAULT_BATCH_SIZE,
) -> np.ndarray:
    """DUIS's SIV variants of every frame, as ``query`` makes them at ``seed``.

    ``run(Request(..., seed=s, variants=make_variants(depth_m, valid, seed=s)))`` picks
    the same frames as ``query(..., seed=s)``; made once, they serve every round of a
    pool.

    Args: as ``Request``'s fields of the same names; ``chunk``: frames per process task.

    Returns:
        (N, M, H, W) float32 depth in metres, NaN at voids.
    """
    depth, mask, refl = _frames(depth_m, valid, reflectance)
    maker = _VariantMaker(
        depth,
        mask,
        refl,
        seed=seed,
        n_variants=n_variants,
        conditions=conditions,
        sensor=sensor,
        method=reconstruct_method,
        n_jobs=n_jobs,
    )
    out = np.empty((len(depth), maker.n_variants, *depth.shape[1:]), np.float32)
    step = max(1, int(chunk))
    with maker:
        for s in range(0, len(depth), step):
            idx = np.arange(s, min(s + step, len(depth)))
            out[idx] = maker(idx)
    return out


def default_conditions(n_variants: int) -> list[tuple[float, float]]:
    """The first M conditions of the default MSPPP x SBR set in spread order (repeated,
    as new photon draws, when M exceeds the set)."""
    base = spread_conditions(condition_set())
    return [base[j % len(base)] for j in range(int(n_variants))]


def _frames(depth_m, valid, reflectance) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    depth = np.asarray(depth_m, dtype=np.float32)
    mask = np.asarray(valid)
    if depth.ndim != 3 or mask.shape != depth.shape:
        raise ValueError(
            f"depth_m and valid must both be (N, H, W) arrays of the frames, got "
            f"{depth.shape} and {mask.shape}."
        )
    if mask.dtype != bool:
        if not np.isin(mask, (0, 1)).all():
            raise ValueError(f"valid must be a bool mask (or 0/1 values), got {mask.dtype}.")
        mask = mask.astype(bool)
    mask = mask & np.isfinite(depth)
    if (depth[mask] < 0).any():
        raise ValueError("depth_m holds negative depths on valid pixels; expected metres >= 0.")
    depth = np.where(mask, depth, np.float32(np.nan))
    refl = None
    if reflectance is not None:
        refl = np.asarray(reflectance, dtype=np.float32)
        if refl.shape != depth.shape:
            raise ValueError(f"reflectance must be {depth.shape} like depth_m, got {refl.shape}.")
    return depth, mask, refl


def _budget(budget, n: int, n_labeled: int) -> int:
    if isinstance(budget, bool) or not isinstance(budget, int | np.integer) or budget < 1:
        raise ValueError(f"budget must be an integer >= 1, got {budget!r}.")
    if budget > n - n_labeled:
        raise ValueError(
            f"budget {budget} is more than the {n - n_labeled} unlabeled frames "
            f"({n} frames, {n_labeled} labeled); ask for at most {n - n_labeled}."
        )
    return int(budget)


def _strategy(method: str, params: dict | None, n_unlabeled: int):
    """The strategy, with N_cand capped at half the pool when not given (module docstring)."""
    params = dict(params or {})
    strategy = get(method, **params)
    fraction = getattr(strategy, "max_cand_fraction", None)
    if "n_cand" not in params and getattr(strategy, "n_cand", None) and fraction:
        cap = int(fraction * n_unlabeled)
        if cap < 1:  # a pool of one frame: ranked whole
            strategy = get(method, **params, n_cand=1, max_cand_fraction=None)
        elif strategy.n_cand > cap:
            strategy = get(method, **params, n_cand=cap)
    check_candidate_pool(strategy, n_unlabeled, key='params["n_cand"]')
    return strategy


def _numpy(x, what: str) -> np.ndarray:
    if hasattr(x, "detach"):  # a torch tensor
        x = x.detach().cpu().numpy()
    try:
        return np.asarray(x, dtype=np.float32)
    except (TypeError, ValueError):
        raise ValueError(
            f"predict returned {what} that are no array ({type(x).__name__})."
        ) from None


class _Model:
    """``predict`` in batches of ``batch_size`` frames: its outputs checked, its frames
    counted and its time kept."""

    def __init__(self, predict: Callable, batch_size: int):
        if not callable(predict):
            raise ValueError(f"predict must be a function, got {type(predict).__name__}.")
        if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
            raise ValueError(f"batch_size must be an integer >= 1, got {batch_size!r}.")
        self.predict, self.batch_size = predict, int(batch_size)
        self.frames, self.seconds = 0, 0.0
        self.task, self.n_classes, self.has_features = "", 0, None
        self.pixel_features = False  # features (B, D, H, W) of a segmenter

    def __call__(self, depth: np.ndarray, valid: np.ndarray):
        """(probs (n, C) or (n, C, H, W), features (n, D[, H, W]) or None)."""
        probs, feats = [], []
        for s in range(0, len(depth), self.batch_size):
            p, f = self._call(depth[s : s + self.batch_size], valid[s : s + self.batch_size])
            probs.append(p)
            feats.append(f)
        return np.concatenate(probs), None if feats[0] is None else np.concatenate(feats)

    def _call(self, depth: np.ndarray, valid: np.ndarray):
        start = time.perf_counter()
        out = self.predict(depth, valid)
        self.seconds += time.perf_counter() - start
        self.frames += len(depth)
        feats = None
        if isinstance(out, tuple | list):
            if len(out) != 2:
                raise ValueError(
                    f"predict returned a tuple of {len(out)} items; expected probabilities, "
                    "or (probabilities, features)."
                )
            out, feats = out
        probs = self._probabilities(_numpy(out, "probabilities"), depth.shape)
        if feats is not None:
            feats = _numpy(feats, "features")
            spatial = (self.task == "segmentation" and feats.ndim == 4) and feats.shape[2:] == (
                depth.shape[1:]
            )
            if len(feats) != len(depth) or not (feats.ndim == 2 or spatial):
                raise ValueError(
                    f"predict returned features of shape {feats.shape} for {len(depth)} "
                    f"frames; expected ({len(depth)}, D)."
                )
            if not np.isfinite(feats).all():
                raise ValueError("predict returned features that are not all finite.")
        if self.has_features is None:
            self.has_features = feats is not None
            self.pixel_features = feats is not None and feats.ndim == 4
        elif self.has_features != (feats is not None):
            raise ValueError("predict returned features for some frames and not for others.")
        return probs, feats

    def _probabilities(self, p: np.ndarray, shape: tuple) -> np.ndarray:
        b, h, w = shape
        task = "classification" if p.ndim == 2 else "segmentation" if p.ndim == 4 else ""
        if not task or len(p) != b or (p.ndim == 4 and p.shape[2:] != (h, w)) or p.shape[1] < 2:
            raise ValueError(
                f"predict returned probabilities of shape {p.shape} for {b} frames of "
                f"{h}x{w}; expected ({b}, C) or ({b}, C, {h}, {w}) with C >= 2 classes."
            )
        if self.task and (task, p.shape[1]) != (self.task, self.n_classes):
            raise ValueError(
                f"predict returned {task} probabilities of {p.shape[1]} classes after "
                f"{self.task} ones of {self.n_classes}."
            )
        self.task, self.n_classes = task, int(p.shape[1])
        sums = p.sum(axis=1)
        if not np.isfinite(p).all() or (p < -1e-6).any() or np.abs(sums - 1).max() > 1e-2:
            raise ValueError(
                "predict must return probabilities (non-negative, summing to 1 over the "
                f"class axis 1, e.g. a softmax), got sums from {np.nanmin(sums):.3g} to "
                f"{np.nanmax(sums):.3g}."
            )
        return p


def _refusal(method: str, needs: frozenset, model: _Model, head) -> str | None:
    """The sentence refusing ``method`` when ``predict`` (and ``head``) cannot meet its
    needs, else None."""
    if "grad_embedding" in needs and not model.has_features:
        return (
            f"{method} needs features from predict (its gradient embedding is built on "
            "them), but predict returned probabilities only; return (probabilities, "
            "features (B, D)) or choose another method."
        )
    if "grad_embedding" in needs and model.task == "segmentation" and not model.pixel_features:
        return (
            f"{method} on a segmenter needs per-pixel features (B, D, H, W) from predict, "
            "but predict returned (B, D) features."
        )
    if "head" in needs and model.task == "segmentation":
        return f"{method} reads a classifier's last layer: it is for classification only."
    if "head" in needs and head is None:
        return (
            f"{method} needs the classifier's last linear layer, which a predict function "
            "does not expose; give Request(head=(weight (C, D), bias (C,), dropout p)) and "
            "features from predict, or choose another method."
        )
    if "head" in needs and not model.has_features:
        return (
            f"{method} needs the features the head's layer reads, but predict returned "
            "probabilities only; return (probabilities, features (B, D))."
        )
    return None


def _pooled(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Mean of (n, k, H, W) over the pixels of ``mask`` (n, H, W): (n, k); an image
    without any averages over all its pixels (``training.forward.pool_pixels``)."""
    m = mask.reshape(len(mask), -1).astype(np.float32)
    m[m.sum(axis=1) == 0] = 1.0
    v = values.reshape(*values.shape[:2], -1)
    return np.einsum("nku,nu->nk", v, m) / m.sum(axis=1)[:, None]


@dataclass(frozen=True)
class _Photons:
    """What a frame's variants are made with, besides the frame."""

    seed: int
    conditions: list
    sensor: SensorParams | None
    method: str


def _variants_of(depth, valid, refl, uids, photons: _Photons) -> np.ndarray:
    """The variants of frames ``uids`` (a process pool's task: top-level, picklable)."""
    return synthesize_variants(
        depth,
        valid,
        photons.conditions,
        rng=[sample_rng(photons.seed, STREAM_VARIANT, int(i)) for i in uids],
        sensor=photons.sensor,
        reflectance=refl,
        method=photons.method,
    )


class _VariantMaker:
    """The SIV variants of frames by index, in this process or ``n_jobs`` of them; a
    context manager (the processes start on first use and stop on exit)."""

    def __init__(self, depth, valid, refl, *, seed, n_variants, conditions, sensor, method, n_jobs):
        self.depth, self.valid, self.refl = depth, valid, refl
        for name, value in (("n_variants", n_variants), ("n_jobs", n_jobs)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}.")
        self.n_variants, self.n_jobs = int(n_variants), int(n_jobs)
        self.conditions = (
            default_conditions(self.n_variants)
            if conditions is None
            else [tuple(c) for c in conditions]
        )
        if len(self.conditions) < self.n_variants:
            raise ValueError(
                f"conditions lists {len(self.conditions)} (msppp, sbr) pairs for "
                f"n_variants = {self.n_variants}; give at least that many."
            )
        self.conditions = self.conditions[: self.n_variants]
        self.photons = _Photons(seed, self.conditions, sensor, method)
        self.seconds = 0.0
        self._pool = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def __call__(self, idx: np.ndarray) -> np.ndarray:
        """(len(idx), M, H, W) float32 variants of frames ``idx``."""
        start = time.perf_counter()
        parts = np.array_split(np.asarray(idx), min(self.n_jobs, len(idx)))
        if len(parts) > 1 and self._pool is None:
            # spawn: a forked child of a process running torch's threads can hang
            context = multiprocessing.get_context("spawn")
            self._pool = ProcessPoolExecutor(self.n_jobs, mp_context=context)
        tasks = [
            (
                self.depth[i],
                self.valid[i],
                None if self.refl is None else self.refl[i],
                i,
                self.photons,
            )
            for i in parts
        ]
        if len(parts) > 1:
            out = np.concatenate(list(self._pool.map(_variants_of, *zip(*tasks, strict=True))))
        else:
            out = _variants_of(*tasks[0])
        self.seconds += time.perf_counter() - start
        return out


def _given_variants(variants, depth: np.ndarray) -> np.ndarray:
    """``Request.variants`` checked against the frames: (N, M, H, W) float32."""
    v = np.asarray(variants)
    if v.ndim != 4 or v.shape[0] != depth.shape[0] or v.shape[2:] != depth.shape[1:]:
        raise ValueError(
            f"variants must be (N, M, H, W) = ({depth.shape[0]}, M, {depth.shape[1]}, "
            f"{depth.shape[2]}) for these frames (make_variants), got {v.shape}."
        )
    if v.shape[1] < 1 or not np.issubdtype(v.dtype, np.floating):
        raise ValueError(f"variants must hold M >= 1 float depth images a frame, got {v.dtype}.")
    return v


class _Groups:
    """Frames and their variants through the model, reduced to the strategy's inputs."""

    def __init__(self, request: Request, model: _Model, depth, valid, refl):
        self.request, self.model, self.depth = request, model, depth
        self.given = None if request.variants is None else _given_variants(request.variants, depth)
        self.maker = None
        if self.given is None:
            self.maker = _VariantMaker(
                depth,
                valid,
                refl,
                seed=request.seed,
                n_variants=request.n_variants,
                conditions=request.conditions,
                sensor=request.sensor,
                method=request.reconstruct_method,
                n_jobs=request.n_jobs,
            )
            self.n_variants = self.maker.n_variants
        else:
            self.n_variants = self.given.shape[1]

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.maker is not None:
            self.maker.__exit__(*exc)

    @property
    def variant_seconds(self) -> float:
        return 0.0 if self.maker is None else self.maker.seconds

    def images(self, idx: np.ndarray, with_variants: bool):
        """(depth, valid) of frames ``idx`` and their variants, (b, G, H, W)."""
        d = self.depth[idx][:, None]
        if with_variants:
            var = self.maker(idx) if self.given is None else self.given[idx]
            d = np.concatenate([d, var.astype(np.float32, copy=False)], axis=1)
        return d, np.isfinite(d)

    def outputs(self, idx: np.ndarray, with_variants: bool, pixel_features: bool = False):
        """probs (b, G, units, C), features (b, G, D), pixel features (b, G, units, D) or
        None, image_valid (b, G, units) or None (classification)."""
        d, v = self.images(idx, with_variants)
        b, g, h, w = d.shape
        probs, feats = self.model(d.reshape(b * g, h, w), v.reshape(b * g, h, w))
        if self.model.task == "classification":
            if feats is None:
                feats = probs
            return probs.reshape(b, g, 1, -1), feats.reshape(b, g, -1), None, None
        obs_valid = np.repeat(v[:, 0], g, axis=0)  # the observed frame's pixels, every image
        c = probs.shape[1]
        pix = None
        if feats is None:
            pooled = _pooled(probs, obs_valid)
        elif feats.ndim == 4:
            pooled = _pooled(feats, obs_valid)
            if pixel_features:
                pix = feats.reshape(b, g, feats.shape[1], -1).transpose(0, 1, 3, 2)
        else:
            pooled = feats
        per_unit = probs.reshape(b, g, c, -1).transpose(0, 1, 3, 2)
        return per_unit, pooled.reshape(b, g, -1), pix, v.reshape(b, g, -1)


def run(request: Request) -> Selection:
    """The frames ``request.method`` picks, with what it cost (``Selection``)."""
    start = time.perf_counter()
    depth, valid, refl = _frames(request.depth_m, request.valid, request.reflectance)
    n = len(depth)
    labeled = as_index_array("labeled", () if request.labeled is None else request.labeled)
    if labeled.size and labeled.max() >= n:
        raise ValueError(f"labeled must index the {n} frames, found {labeled.max()}.")
    budget = _budget(request.budget, n, len(labeled))
    unlabeled = np.setdiff1d(np.arange(n), labeled)
    strategy = _strategy(request.method, request.params, len(unlabeled))
    model = _Model(request.predict, request.batch_size)
    groups = _Groups(request, model, depth, valid, refl)
    with groups:
        arrays = _inputs(request, frozenset(strategy.needs), groups, unlabeled, labeled)
    _fill_required(strategy, model)
    inputs = StrategyInputs(unlabeled_idx=unlabeled, labeled_idx=labeled, **arrays)
    select_start = time.perf_counter()
    picked = strategy.select(inputs, budget, acquire_rng(request.seed))
    picks = check_picks(request.method, picked, inputs, budget)
    now = time.perf_counter()
    seconds = {
        "predict": model.seconds,
        "variants": groups.variant_seconds,
        "select": now - select_start,
        "total": now - start,
    }
    return Selection(picks, model.frames, seconds, model.task)


def _inputs(request: Request, needs: frozenset, groups: _Groups, unlabeled, labeled) -> dict:
    """The arrays of the StrategyInputs ``needs`` asks for: the unlabeled frames (with
    their variants for DUIS's group needs) through ``predict`` chunk by chunk, reduced
    to per-frame scores and features at once, then the labeled frames' features."""
    model = groups.model
    with_variants = bool(needs & GROUP_NEEDS)
    per_call = max(1, request.batch_size // (1 + groups.n_variants if with_variants else 1))
    scored = needs - {"labeled_features", "head"}
    parts: dict[str, list[np.ndarray]] = {}
    for s in range(0, len(unlabeled) if scored else 0, per_call):
        probs, feats, pix, image_valid = groups.outputs(
            unlabeled[s : s + per_call], with_variants, pixel_features="grad_embedding" in needs
        )
        if s == 0:  # the first answer tells what predict gives: refuse before the rest
            _refuse(request, needs, model)
        for name, value in scores_from_outputs(
            scored, model.task, probs, feats, pix_feats=pix, image_valid=image_valid
        ):
            parts.setdefault(name, []).append(value)
    if "labeled_features" in needs:
        dim = parts["features"][0].shape[1]
        parts["labeled_features"] = [np.zeros((0, dim), np.float32)]
        for s in range(0, len(labeled), request.batch_size):
            _, feats, _, _ = groups.outputs(labeled[s : s + request.batch_size], False)
            parts["labeled_features"].append(feats[:, 0])
    arrays = {}
    for name, chunks in parts.items():
        value = np.concatenate(chunks)
        arrays[name] = value.astype(np.float32) if value.ndim == 2 else value.astype(np.float64)
    if "head" in needs:
        arrays.update(_head(request.head, arrays))
    return arrays


def _refuse(request: Request, needs: frozenset, model: _Model) -> None:
    message = _refusal(request.method, needs, model, request.head)
    if message:
        raise ValueError(message)


def _head(head, arrays: dict) -> dict:
    """``Request.head`` as the StrategyInputs fields of the need "head"."""
    try:
        weight, bias, dropout = head
        weight = np.asarray(weight, dtype=np.float32)
        bias = np.asarray(bias, dtype=np.float64)
        dropout = float(dropout)
    except (TypeError, ValueError):
        raise ValueError(
            "head must be (weight (C, D), bias (C,), dropout p) of the classifier's last layer."
        ) from None
    dim = arrays["features"].shape[1]
    if weight.ndim != 2 or weight.shape[1] != dim or bias.shape != weight.shape[:1]:
        raise ValueError(
            f"head's weight must be (C, {dim}) on predict's {dim} features and its bias (C,), "
            f"got {weight.shape} and {bias.shape}."
        )
    return {"head_weight": weight, "head_bias": bias, "head_dropout": np.float64(dropout)}


def _fill_required(strategy, model: _Model) -> None:
    """A strategy's required class count (probcover's ``n_classes``) from ``predict``."""
    required = getattr(strategy, "required", ())
    if "n_classes" in required and strategy.n_classes is None and model.n_classes:
        strategy.n_classes = model.n_classes

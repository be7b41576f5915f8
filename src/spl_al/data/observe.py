"""Observed SPL images: clean depth seen through the photon engine at each sample's
own imaging condition, and the conditions themselves (MSPPP levels and SBR).

An observed image is ``reconstruct(simulate_photons(clean depth, reflectance,
msppp, sbr))``: Algorithm 1's measurement model followed by ML reconstruction
(``spl_al.photon``). It keeps the voids and depth noise of its photon budget, and
its reconstructed reflectivity is what SIV later simulates variants from.

Default conditions: MSPPP levels high = 10, medium = 5, low = 2 signal photons per
pixel (the range of the SPL literature, docs/method.md section 2) and SBR drawn from
{0.2, 1, 5} (background 5x the signal, equal, a fifth). Levels are assigned
balanced within each class and split, so every per-level test subset has the same
class mix; SBR is drawn uniformly at random.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from spl_al.data.dataset import LEVELS
from spl_al.data.parallel import chunk_indices, default_workers, run_chunks
from spl_al.data.seeds import STREAM_OBSERVE, sample_rng
from spl_al.photon import Condition, PhotonScene, SensorParams, reconstruct, simulate_photons
from spl_al.photon.effects import ObservationModel, observe_photons
from spl_al.photon.siv import photon_window

DEFAULT_LEVELS: dict[str, float] = {"high": 10.0, "medium": 5.0, "low": 2.0}
DEFAULT_SBR: tuple[float, ...] = (0.2, 1.0, 5.0)


def check_levels(levels: Mapping) -> dict[str, object]:
    """Validate MSPPP levels: names among high/medium/low, each a value > 0 or a
    (low, high) range drawn log-uniformly."""
    if not levels:
        raise ValueError("levels must name at least one MSPPP level.")
    out = {}
    for name, value in levels.items():
        if name not in LEVELS:
            raise ValueError(f"levels has key {name!r}; expected names among {LEVELS}.")
        if isinstance(value, Sequence) and not isinstance(value, str):
            lo, hi = (float(v) for v in value)
            if not 0 < lo <= hi or not np.isfinite(hi):
                raise ValueError(
                    f"levels[{name!r}] must be a range (low, high) with 0 < low <= high, "
                    f"got {value!r}."
                )
            out[name] = [lo, hi]
        else:
            v = float(value)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(
                    f"levels[{name!r}] must be > 0 signal photons per pixel, got {value!r}."
                )
            out[name] = v
    return out


def check_sbr_values(sbr_values) -> list[float]:
    """Validate signal-to-background ratios: one or more values > 0, as floats."""
    values = [float(v) for v in np.atleast_1d(sbr_values)]
    if not values or any(not v > 0 for v in values):
        raise ValueError(f"sbr_values must be one or more values > 0, got {sbr_values!r}.")
    return values


def condition_set(
    levels: Mapping = DEFAULT_LEVELS, sbr_values=DEFAULT_SBR
) -> list[tuple[float, float]]:
    """Every (msppp, sbr) pair of fixed-valued levels x SBR values (ranges use their
    geometric mean): the default condition set of the SIV variants."""
    levels = check_levels(levels)
    out = []
    for value in levels.values():
        m = float(np.sqrt(value[0] * value[1])) if isinstance(value, list) else value
        out += [(m, s) for s in check_sbr_values(sbr_values)]
    return out


def assign_conditions(
    groups: np.ndarray, split: np.ndarray, *, levels: Mapping, sbr_values, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-sample (msppp, sbr, level), levels balanced within every group and split.

    Args:
        groups: (N,) int group of each sample (its class, or 0 for segmentation).
        split: (N,) str split of each sample.

    Returns:
        msppp (N,) float64, sbr (N,) float64, level (N,) str.
    """
    levels = check_levels(levels)
    sbr_values = check_sbr_values(sbr_values)
    names = list(levels)
    n = len(groups)
    level = np.empty(n, dtype="<U7")
    for s in np.unique(split):
        # Shuffle within each group, keep groups contiguous, then deal the levels out
        # in turn: balanced (to within one) in every group and over the whole split.
        idx = np.flatnonzero(split == s)
        order = np.lexsort((rng.permutation(idx.size), groups[idx]))
        start = rng.integers(len(names))
        level[idx[order]] = [names[(start + k) % len(names)] for k in range(idx.size)]
    msppp = np.empty(n)
    for name, value in levels.items():
        pick = level == name
        if isinstance(value, list):
            msppp[pick] = np.exp(rng.uniform(np.log(value[0]), np.log(value[1]), int(pick.sum())))
        else:
            msppp[pick] = value
    sbr = np.asarray(sbr_values)[rng.integers(len(sbr_values), size=n)]
    return msppp, sbr.astype(np.float64), level


def image_through_photons(
    scene: PhotonScene, condition: Condition, rng: np.random.Generator, *, method="pooled"
):
    """``reconstruct(simulate_photons(...))`` of one image, computed on the bounding box
    of its returns (the rest of the frame has no photon), pasted back into the frame.

    ``scene.valid`` must be given (the returns' mask).

    Returns the Reconstruction's (depth (H, W) float32 NaN at voids, reflectivity
    (H, W) float32, 0 at voids).
    """
    valid = scene.valid
    rows, cols = photon_window(valid)
    depth = np.full(valid.shape, np.nan, np.float32)
    refl_out = np.zeros(valid.shape, np.float32)
    events = simulate_photons(scene.crop(rows, cols), condition, rng)
    rec = reconstruct(events, events.shape, condition.sensor, method=method)
    depth[rows, cols] = rec.depth_m
    refl_out[rows, cols] = rec.reflectivity
    return depth, refl_out


def observe_image(
    depth_m,
    reflectance,
    condition: Condition,
    rng: np.random.Generator,
    *,
    method="pooled",
    model: ObservationModel | None = None,
    range_compensated: bool = False,
):
    """One observed image of a clean depth image (NaN = no return).

    ``model`` None: Algorithm 1 (``simulate_photons``, on the returns' bounding box);
    else the fuller sensor model ``observe_photons`` over the whole frame (background
    falls on pixels without a return too), reconstructed with background censoring
    (``reconstruct(..., censor=True)``: what only background reached stays void).
    ``range_compensated``: the reflectance has no range falloff (``observe_photons``).

    Returns (depth (H, W) float32 NaN at voids, reflectivity (H, W) float32 estimated
    signal photons per pixel, 0 at voids). An image without any return stays void.
    """
    depth = np.asarray(depth_m)
    valid = np.isfinite(depth)
    if not valid.any():
        return np.full(depth.shape, np.nan, np.float32), np.zeros(depth.shape, np.float32)
    refl = None if reflectance is None else np.where(valid, reflectance, 0.0)
    if refl is not None and not (refl[valid] > 0).any():
        refl = None  # a scene without any reflectance: uniform, as for external data
    scene = PhotonScene(depth, refl, valid)
    if model is None:
        return image_through_photons(scene, condition, rng, method=method)
    events = observe_photons(
        scene, condition, rng, model=model, range_compensated=range_compensated
    )
    rec = reconstruct(events, events.shape, condition.sensor, method=method, censor=True)
    return rec.depth_m.astype(np.float32), rec.reflectivity.astype(np.float32)


@dataclass(frozen=True)
class Imaging:
    """How a clean scene becomes an observed image: the same for every sample of a set.

    sensor: the SPL's timing (bins, jitter, reach).
    method: the ``spl_al.photon.reconstruct`` method.
    model: the fuller sensor model (``observe_image``); None: Algorithm 1.
    range_compensated: the scene reflectance has no range falloff (street scenes).
    """

    sensor: SensorParams
    method: str = "pooled"
    model: ObservationModel | None = None
    range_compensated: bool = False

    def observe(self, depth_m, reflectance, *, msppp: float, sbr: float, rng):
        """``observe_image`` of one clean (H, W) depth image in metres under this imaging."""
        return observe_image(
            depth_m,
            reflectance,
            Condition(msppp, sbr, self.sensor),
            rng,
            method=self.method,
            model=self.model,
            range_compensated=self.range_compensated,
        )


def _observe_chunk(depth, reflectance, msppp, sbr, uid, *, seed: int, imaging: Imaging):
    out_d = np.empty(depth.shape, np.float32)
    out_r = np.empty(depth.shape, np.float32)
    for k in range(len(depth)):
        rng = sample_rng(seed, STREAM_OBSERVE, uid[k])
        refl = None if reflectance is None else reflectance[k]
        out_d[k], out_r[k] = imaging.observe(depth[k], refl, msppp=msppp[k], sbr=sbr[k], rng=rng)
    return out_d, out_r


def observation_of(dataset) -> tuple[ObservationModel | None, bool]:
    """The sensor model a synthetic dataset's observed images were made with (None:
    Algorithm 1, as before the model existed) and whether its scene reflectance is
    range-compensated (street scenes)."""
    params = dataset.meta.get("observation")
    model = None if params is None else ObservationModel.from_dict(params)
    if model is not None and model.is_algorithm1:
        model = None
    return model, dataset.meta.get("generator") == "spl_al.scenes.street"


def observe(
    clean_depth_m: np.ndarray,
    reflectance: np.ndarray | None,
    *,
    msppp: np.ndarray,
    sbr: np.ndarray,
    sensor: SensorParams,
    seed: int,
    uid: np.ndarray | None = None,
    workers: int | None = 1,
    **imaging,
) -> tuple[np.ndarray, np.ndarray]:
    """Observed images of N clean depth images, each at its own (msppp, sbr).

    Sample k's photons come from ``sample_rng(seed, STREAM_OBSERVE, uid[k])``, so the
    result does not depend on ``workers`` or on which other samples are observed.

    Args:
        clean_depth_m: (N, H, W) depth in metres, NaN where nothing returns.
        reflectance: (N, H, W) scene reflectance, or None for uniform.
        msppp, sbr: (N,) condition of each sample (signal photons per pixel, and the
            signal-to-background ratio).
        sensor: the SPL's timing.
        seed: the seed of the photon draws.
        uid: (N,) sample ids (default 0..N-1).
        workers: processes (None = all cores; the result does not depend on it).
        **imaging: ``method`` (default "pooled"), ``model`` and ``range_compensated``
            of ``Imaging`` (None model: Algorithm 1).

    Returns:
        depth (N, H, W) float32 NaN at voids, reflectivity (N, H, W) float32.
    """
    setup = Imaging(sensor, **imaging)
    clean = np.asarray(clean_depth_m, dtype=np.float32)
    n = len(clean)
    uid = np.arange(n) if uid is None else np.asarray(uid)
    msppp, sbr = np.broadcast_to(msppp, (n,)), np.broadcast_to(sbr, (n,))
    workers = default_workers() if workers is None else workers
    args = [
        (
            clean[c],
            None if reflectance is None else reflectance[c],
            msppp[c],
            sbr[c],
            uid[c],
        )
        for c in chunk_indices(n, workers)
    ]
    results = run_chunks(_observe_chunk, args, workers, seed=seed, imaging=setup)
    if not results:
        return np.empty_like(clean), np.empty_like(clean)
    return np.concatenate([r[0] for r in results]), np.concatenate([r[1] for r in results])

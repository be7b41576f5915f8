"""Synthetic imaging variants (SIV): Algorithm 1 of the paper, end to end.

``synthesize_variant`` makes one variant of one scene; ``synthesize_variants`` makes
the M variants of every frame of a batch, each on the bounding box of the frame's
returns (``photon_window``: the rest of the frame has no photon, and the result is the
same bit for bit).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from spl_al.photon.reconstruct import reconstruct
from spl_al.photon.scene import Condition, PhotonScene, check_condition
from spl_al.photon.sensor import SensorParams
from spl_al.photon.simulate import simulate_photons

# Pixels farther than this from every return hold no photon; the photon engine's
# neighbourhoods reach 2 pixels (5x5 candidates), so cropping to the returns'
# bounding box plus this margin leaves every result unchanged (tested bit for bit).
PHOTON_MARGIN_PX = 3


def photon_window(valid: np.ndarray, margin: int = PHOTON_MARGIN_PX) -> tuple[slice, slice]:
    """Row and column slices of the bounding box of ``valid`` grown by ``margin``."""
    rows = np.flatnonzero(valid.any(axis=1))
    cols = np.flatnonzero(valid.any(axis=0))
    return (
        slice(max(int(rows[0]) - margin, 0), int(rows[-1]) + margin + 1),
        slice(max(int(cols[0]) - margin, 0), int(cols[-1]) + margin + 1),
    )


def synthesize_variant(
    scene: PhotonScene,
    condition: Condition,
    rng: np.random.Generator,
    *,
    method: str = "pooled",
) -> np.ndarray:
    """One synthetic variant I_syn,j of an observed depth image at a condition (msppp, sbr).

    Simulates the photons of Algorithm 1 (``simulate_photons``) from the observed
    depth and reflectance, then reconstructs depth from them (``reconstruct``), so
    the variant carries the voids and noise of that photon budget.

    Args: as ``simulate_photons``; ``method`` as ``reconstruct``.

    Returns:
        (rows, cols) float64 depth in metres, NaN at voids.
    """
    events = simulate_photons(scene, condition, rng)
    return reconstruct(events, events.shape, condition.sensor, method=method).depth_m


def synthesize_variants(
    depth_m,
    valid,
    conditions,
    *,
    rng: np.random.Generator | Sequence[np.random.Generator],
    sensor: SensorParams | None = None,
    reflectance=None,
    method: str = "pooled",
) -> np.ndarray:
    """The SIV variants of a batch of frames: variant j of every frame at ``conditions[j]``.

    Each variant is ``synthesize_variant`` of the frame (its depth where ``valid``, its
    reflectance) at that condition, computed on the bounding box of the frame's returns.

    Args:
        depth_m: (B, H, W) depth in metres (read where ``valid`` only).
        valid: (B, H, W) bool, the pixels with a return; a frame without any gives
            all-void variants.
        conditions: M (msppp, sbr) pairs.
        rng: one generator for the whole batch, or one per frame (B of them): then a
            frame's variants do not depend on the other frames of its batch.
        sensor: the timing the photons are simulated and reconstructed with; default
            ``SensorParams.paper_real()`` (12,500 bins of 80 ps, 150 m of reach, 520 ps
            of jitter, the paper's scanning sensor). Its jitter sets the depth noise
            of the variants; a depth beyond its reach is a ValueError.
        reflectance: (B, H, W) reflectance (any scale, >= 0), or None: uniform, every
            valid pixel receives the condition's MSPPP on average. A frame whose
            reflectance is zero on every valid pixel is taken as uniform.
        method: reconstruction method (``reconstruct``).

    Returns:
        (B, M, H, W) float32 depth, NaN at voids.
    """
    depth = np.asarray(depth_m)
    mask = np.asarray(valid, dtype=bool)
    if depth.ndim != 3 or mask.shape != depth.shape:
        raise ValueError(
            f"depth_m and valid must both be (B, H, W), got {depth.shape} and {mask.shape}."
        )
    conds = [check_condition(m, s) for m, s in conditions]
    sensor = SensorParams.paper_real() if sensor is None else sensor
    refl = None if reflectance is None else np.asarray(reflectance)
    if refl is not None and refl.shape != depth.shape:
        raise ValueError(f"reflectance must be {depth.shape} like depth_m, got {refl.shape}.")
    rngs = [rng] * len(depth) if isinstance(rng, np.random.Generator) else list(rng)
    if len(rngs) != len(depth):
        raise ValueError(f"rng gives {len(rngs)} generators for {len(depth)} frames.")
    out = np.full((len(depth), len(conds), *depth.shape[1:]), np.nan, np.float32)
    for b in range(len(depth)):
        if not mask[b].any():
            continue
        rows, cols = photon_window(mask[b])
        v = mask[b, rows, cols]
        r = None if refl is None else np.where(v, refl[b, rows, cols], 0.0)
        if r is not None and not (r[v] > 0).any():
            r = None
        scene = PhotonScene(np.where(v, depth[b, rows, cols], 0.0), r, v)
        for j, (msppp, sbr) in enumerate(conds):
            out[b, j, rows, cols] = synthesize_variant(
                scene, Condition(msppp, sbr, sensor), rngs[b], method=method
            )
    return out

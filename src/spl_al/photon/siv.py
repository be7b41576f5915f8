"""Synthetic imaging variants (SIV): Algorithm 1 of the paper, end to end."""

from __future__ import annotations

import numpy as np

from spl_al.photon.reconstruct import reconstruct
from spl_al.photon.scene import Condition, PhotonScene
from spl_al.photon.simulate import simulate_photons


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

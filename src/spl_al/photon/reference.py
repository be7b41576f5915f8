"""A literal, loop-per-pixel transcription of the paper's Algorithm 1 (SIV, steps 1-5).

It is slow on purpose: it is the yardstick the vectorised ``simulate_photons`` is
checked against (tests compare their statistics) and timed against (the photon
benchmark). It lives in the package rather than under tests/ because the benchmark
needs it too. Do not use it for data.
"""

from __future__ import annotations

import math

import numpy as np

from spl_al.photon.events import PhotonEvents
from spl_al.photon.scene import Condition, PhotonScene, check_scene
from spl_al.photon.sensor import SPEED_OF_LIGHT_M_PER_S


def simulate_photons_loop(scene: PhotonScene, condition: Condition, rng: np.random.Generator):
    """Algorithm 1 pixel by pixel, photon by photon; same arguments as ``simulate_photons``."""
    msppp, sbr, sensor = condition.msppp, condition.sbr, condition.sensor
    depth, refl, valid, _ = check_scene(scene, sensor)
    rows, cols = depth.shape
    valid_pixels = [(r, c) for r in range(rows) for c in range(cols) if valid[r, c]]
    sigma = sensor.sigma_bins
    mean_signal = sum(msppp * refl[r, c] for r, c in valid_pixels) / len(valid_pixels)
    pixel, bins, is_signal = [], [], []
    for r, c in valid_pixels:
        t_obs = round(2.0 * depth[r, c] / (SPEED_OF_LIGHT_M_PER_S * sensor.bin_width_s))
        for _ in range(rng.poisson(msppp * refl[r, c])):
            t = round(t_obs + sigma * rng.standard_normal())
            pixel.append(r * cols + c)
            bins.append(min(max(t, 0), sensor.t_max))
            is_signal.append(True)
        n_bkg = rng.poisson(mean_signal / sbr) if math.isfinite(sbr) else 0
        for _ in range(n_bkg):
            pixel.append(r * cols + c)
            bins.append(int(rng.integers(0, sensor.t_max + 1)))
            is_signal.append(False)
    return PhotonEvents(
        np.asarray(pixel, dtype=np.int32),
        np.asarray(bins, dtype=np.int32),
        np.asarray(is_signal, dtype=bool),
        (rows, cols),
    )

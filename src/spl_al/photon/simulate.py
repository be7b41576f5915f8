"""Photon simulation: the SPL measurement model of SIV (docs/method.md section 2, Algorithm 1)."""

from __future__ import annotations

import numpy as np

from spl_al.photon.events import PhotonEvents
from spl_al.photon.scene import Condition, PhotonScene, check_scene


def simulate_photons(
    scene: PhotonScene, condition: Condition, rng: np.random.Generator
) -> PhotonEvents:
    """Simulate the photons one SPL frame detects at condition (msppp, sbr).

    Implements steps 1-5 of Algorithm 1 for every valid pixel p, with A normalised
    to unit mean over the valid set P:

        t_obs(p) = round(2 d(p) / (c dt))
        n_sig(p) ~ Poisson(msppp * A(p)),  bins = clip(round(t_obs + sigma N(0, 1)), 0, T_max)
        n_bkg(p) ~ Poisson(mean_P(msppp * A) / sbr),  bins ~ Uniform{0..T_max}

    with sigma = pulse_sigma_s / bin_width_s. Invalid pixels detect nothing.

    Args:
        scene: the depth image (depth, reflectance A, valid pixels P).
        condition: msppp, sbr and the sensor's timing (dt, sigma, T_max).
        rng: the generator every draw comes from.

    Returns:
        PhotonEvents with signal events first, then background events.
    """
    msppp, sbr, sensor = condition.msppp, condition.sbr, condition.sensor
    _, refl, valid, t_obs = check_scene(scene, sensor)
    pix = np.flatnonzero(valid)
    signal_rate = msppp * refl.ravel()[pix]

    n_sig = rng.poisson(signal_rate)
    sig_pixel = np.repeat(pix, n_sig)
    jitter = rng.standard_normal(sig_pixel.size) * sensor.sigma_bins
    sig_bin = np.rint(np.repeat(t_obs.ravel()[pix], n_sig) + jitter)
    np.clip(sig_bin, 0, sensor.t_max, out=sig_bin)

    # The expected signal level, not the realised count, sets the background rate.
    background_rate = signal_rate.mean() / sbr
    n_bkg = rng.poisson(background_rate, size=pix.size)
    bkg_pixel = np.repeat(pix, n_bkg)
    bkg_bin = rng.integers(0, sensor.t_max + 1, size=bkg_pixel.size)

    return PhotonEvents(
        pixel=np.concatenate([sig_pixel, bkg_pixel]).astype(np.int32),
        bin=np.concatenate([sig_bin.astype(np.int32), bkg_bin.astype(np.int32)]),
        is_signal=np.concatenate(
            [np.ones(sig_pixel.size, dtype=bool), np.zeros(bkg_pixel.size, dtype=bool)]
        ),
        shape=(int(valid.shape[0]), int(valid.shape[1])),
    )

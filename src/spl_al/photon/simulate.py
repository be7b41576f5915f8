"""Photon simulation: the SPL measurement model of SIV (docs/method.md section 2, Algorithm 1)."""

from __future__ import annotations

import numpy as np

from spl_al.photon.events import PhotonEvents
from spl_al.photon.sensor import SensorParams


def check_scene(depth_m, reflectance, valid, sensor: SensorParams):
    """Validate a depth image and return (depth_m, unit-mean reflectance, valid, t_obs).

    Returns float64 depth (rows, cols), float64 reflectance A normalised to unit mean
    over the valid pixels (rows, cols; 0 outside them), bool valid (rows, cols) and
    int64 t_obs = round(2 d / (c dt)) on the valid pixels (rows, cols; 0 outside).
    Raises ValueError naming the argument for every malformed input.
    """
    depth = np.asarray(depth_m, dtype=np.float64)
    if depth.ndim != 2:
        raise ValueError(f"depth_m must be a 2-D image (rows, cols), got shape {depth.shape}.")
    if valid is None:
        valid = np.isfinite(depth)
    valid = np.asarray(valid)
    if valid.shape != depth.shape:
        raise ValueError(
            f"valid has shape {valid.shape}, expected the shape of depth_m {depth.shape}."
        )
    if valid.dtype != bool:
        if not np.isin(valid, (0, 1)).all():
            raise ValueError("valid must be a boolean mask (or 0/1 values).")
        valid = valid.astype(bool)
    if not valid.any():
        raise ValueError("valid marks no pixel: the image has no valid depth to simulate.")
    d = depth[valid]
    if not np.isfinite(d).all():
        raise ValueError(
            f"depth_m holds {int((~np.isfinite(d)).sum())} NaN or inf values on valid pixels; "
            "mark them invalid in `valid`."
        )
    if (d < 0).any():
        raise ValueError(f"depth_m holds negative depths on valid pixels (min {d.min():.3g} m).")
    t_obs = np.zeros(depth.shape, dtype=np.int64)
    t_obs[valid] = sensor.depth_to_bin(d)
    if t_obs.max() > sensor.t_max:
        raise ValueError(
            f"depth_m reaches {d.max():.3f} m, beyond the sensor's reach of "
            f"{sensor.max_depth_m:.3f} m (T_max = {sensor.t_max} bins of "
            f"{sensor.bin_width_s * 1e12:.4g} ps); use a sensor with more or wider bins."
        )
    if reflectance is None:
        refl = valid.astype(np.float64)
    else:
        refl = np.asarray(reflectance, dtype=np.float64)
        if refl.shape != depth.shape:
            raise ValueError(
                f"reflectance has shape {refl.shape}, expected the shape of depth_m {depth.shape}."
            )
        r = refl[valid]
        if not np.isfinite(r).all() or (r < 0).any():
            raise ValueError("reflectance must be finite and >= 0 on valid pixels.")
        mean_r = r.mean()
        if mean_r <= 0:
            raise ValueError("reflectance is zero on every valid pixel; expected a positive mean.")
        refl = np.where(valid, refl / mean_r, 0.0)
    return depth, refl, valid, t_obs


def check_condition(msppp, sbr) -> tuple[float, float]:
    """(msppp, sbr) as floats; a ValueError unless MSPPP is finite and > 0 and SBR > 0."""
    msppp = float(msppp)
    sbr = float(sbr)
    if not (np.isfinite(msppp) and msppp > 0):
        raise ValueError(
            f"msppp must be a finite number > 0 signal photons per pixel, got {msppp!r}."
        )
    if not sbr > 0 or np.isnan(sbr):
        raise ValueError(f"sbr must be > 0 (np.inf for no background), got {sbr!r}.")
    return msppp, sbr


def simulate_photons(
    depth_m,
    reflectance,
    valid,
    msppp: float,
    sbr: float,
    sensor: SensorParams,
    rng: np.random.Generator,
) -> PhotonEvents:
    """Simulate the photons one SPL frame detects at condition (msppp, sbr).

    Implements steps 1-5 of Algorithm 1 for every valid pixel p, with A normalised
    to unit mean over the valid set P:

        t_obs(p) = round(2 d(p) / (c dt))
        n_sig(p) ~ Poisson(msppp * A(p)),  bins = clip(round(t_obs + sigma N(0, 1)), 0, T_max)
        n_bkg(p) ~ Poisson(mean_P(msppp * A) / sbr),  bins ~ Uniform{0..T_max}

    with sigma = pulse_sigma_s / bin_width_s. Invalid pixels detect nothing.

    Args:
        depth_m: (rows, cols) depth in metres; ignored where ``valid`` is False.
        reflectance: (rows, cols) albedo or signal intensity, any scale; None = uniform.
        valid: (rows, cols) bool mask of pixels with a return; None = finite depths.
        msppp: mean signal photons per valid pixel, > 0.
        sbr: signal-to-background ratio, > 0 (``np.inf`` for no background).
        sensor: timing parameters.
        rng: the generator every draw comes from.

    Returns:
        PhotonEvents with signal events first, then background events.
    """
    msppp, sbr = check_condition(msppp, sbr)
    _, refl, valid, t_obs = check_scene(depth_m, reflectance, valid, sensor)
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

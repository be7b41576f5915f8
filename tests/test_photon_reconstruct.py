"""Reconstruction from photons: accuracy against the physics, and real captures."""

from __future__ import annotations

import numpy as np
import pytest

from spl_al.photon import (
    ML_METHODS,
    Condition,
    PhotonScene,
    SensorParams,
    load_mat,
    reconstruct,
    simulate_photons,
    synthesize_variant,
)

SENSOR = SensorParams.tabletop()


def error_bins(depth, rec, sensor=SENSOR):
    """Absolute depth error in bins of the reconstructed pixels (voids: NaN)."""
    return np.abs(rec.depth_m - depth) / sensor.bin_depth_m


@pytest.mark.parametrize("method", ML_METHODS)
def test_noise_free_reconstruction_is_within_half_a_bin(scene, method):
    sensor = SensorParams(bin_width_s=80e-12, pulse_sigma_s=0.0, n_bins=1024)
    ev = simulate_photons(
        PhotonScene(scene), Condition(50.0, np.inf, sensor), np.random.default_rng(0)
    )
    rec = reconstruct(ev, scene.shape, sensor, method=method)
    assert rec.valid.all()
    assert np.max(np.abs(rec.depth_m - scene)) <= 0.5 * sensor.bin_depth_m + 1e-12


@pytest.mark.parametrize("method", ML_METHODS)
def test_error_falls_as_photons_and_sbr_rise(scene, method):
    def median_and_outliers(msppp, sbr, seed):
        ev = simulate_photons(
            PhotonScene(scene), Condition(msppp, sbr, SENSOR), np.random.default_rng(seed)
        )
        err = error_bins(scene, reconstruct(ev, scene.shape, SENSOR, method=method))
        return np.nanmedian(err), np.nanmean(err > 10)

    low, high = median_and_outliers(2, 1.0, 1), median_and_outliers(10, 1.0, 1)
    assert high[0] < 0.8 * low[0] and high[1] <= low[1]
    noisy, clean = median_and_outliers(5, 0.2, 2), median_and_outliers(5, 5.0, 2)
    assert clean[0] < noisy[0] and clean[1] < noisy[1]


def test_pooled_beats_per_pixel_ml_at_low_sbr(scene):
    ev = simulate_photons(PhotonScene(scene), Condition(2.0, 0.2, SENSOR), np.random.default_rng(3))
    out_lmf = np.nanmean(error_bins(scene, reconstruct(ev, scene.shape, SENSOR, method="lmf")) > 10)
    out_pooled = np.nanmean(
        error_bins(scene, reconstruct(ev, scene.shape, SENSOR, method="pooled")) > 10
    )
    assert out_pooled < 0.5 * out_lmf


def test_high_sbr_error_shrinks_as_one_over_sqrt_n():
    """With n signal photons, the ML depth has std sqrt(sigma^2 + 1/12) / sqrt(n) bins."""
    sensor = SensorParams(bin_width_s=80e-12, pulse_sigma_s=2 * 80e-12, n_bins=1024)
    depth = np.full((128, 128), 5.0)
    ev = simulate_photons(
        PhotonScene(depth), Condition(5.0, 100.0, sensor), np.random.default_rng(4)
    )
    rec = reconstruct(ev, depth.shape, sensor, method="lmf")
    n_signal = np.bincount(ev.pixel[ev.is_signal], minlength=depth.size).reshape(depth.shape)
    residual = rec.depth_m / sensor.bin_depth_m - sensor.depth_to_bin(5.0)
    sigma_eff = np.sqrt(sensor.sigma_bins**2 + 1 / 12)
    for n in (2, 4, 6, 8):
        sel = (n_signal == n) & (rec.counts == n)  # no background photon in the pixel
        assert sel.sum() > 500
        assert residual[sel].std() == pytest.approx(sigma_eff / np.sqrt(n), rel=0.12)


@pytest.mark.parametrize("method", ML_METHODS)
def test_reflectivity_and_background_estimates(scene, method):
    refl = np.ones(scene.shape)
    refl[:, 32:] = 3.0
    ev = simulate_photons(
        PhotonScene(scene, reflectance=refl), Condition(8.0, 1.0, SENSOR), np.random.default_rng(5)
    )
    rec = reconstruct(ev, scene.shape, SENSOR, method=method)
    interior = np.zeros(scene.shape, bool)
    interior[:, 4:28] = True
    dark, bright = rec.reflectivity[interior].mean(), rec.reflectivity[:, 36:60].mean()
    assert dark == pytest.approx(4.0, rel=0.1) and bright == pytest.approx(12.0, rel=0.1)
    assert rec.background.mean() == pytest.approx(8.0, rel=0.1)
    assert rec.counts.sum() == len(ev)


def test_pixels_without_photons_are_voids(scene):
    ev = simulate_photons(
        PhotonScene(scene), Condition(0.5, 10.0, SENSOR), np.random.default_rng(6)
    )
    rec = reconstruct(ev, scene.shape, SENSOR)
    np.testing.assert_array_equal(rec.valid, rec.counts > 0)
    assert np.isnan(rec.depth_m[~rec.valid]).all()
    assert (rec.reflectivity[~rec.valid] == 0).all()
    assert 0.3 < (~rec.valid).mean() < 0.8


def test_synthesize_variant_is_seeded_and_keeps_the_image_shape(scene):
    a = synthesize_variant(
        PhotonScene(scene), Condition(3.0, 1.0, SENSOR), np.random.default_rng(7)
    )
    b = synthesize_variant(
        PhotonScene(scene), Condition(3.0, 1.0, SENSOR), np.random.default_rng(7)
    )
    assert a.shape == scene.shape
    np.testing.assert_array_equal(a, b)
    assert np.nanmedian(np.abs(a - scene)) < 2 * SENSOR.bin_depth_m


def test_real_capture_shows_the_wall_and_the_vehicle(ugv45m_dir):
    sensor = SensorParams.ugv45m()
    ev = load_mat(ugv45m_dir / "car_20.mat")
    assert ev.shape == (64, 64) and 30_000 < len(ev) < 40_000
    summed = np.bincount(ev.bin, minlength=sensor.n_bins)
    assert sensor.bin_to_depth(np.argmax(summed)) == pytest.approx(67.0, abs=1.5)
    rec = reconstruct(ev, ev.shape, sensor)
    assert rec.valid.mean() > 0.95
    depth = rec.depth_m
    assert np.nanmedian(depth) == pytest.approx(67.0, abs=1.5)  # the wall fills most of the frame
    lower = depth[32:, :]
    assert np.mean((lower > 61.0) & (lower < 65.0)) > 0.05  # the vehicle, lower half
    assert np.mean((depth > 44.0) & (depth < 48.0)) > 0.01  # the return at ~46 m


def test_real_capture_column_major_order_matters(ugv45m_dir):
    f = load_mat(ugv45m_dir / "car_20.mat", order="F")
    c = load_mat(ugv45m_dir / "car_20.mat", order="C")
    assert len(f) == len(c)
    np.testing.assert_array_equal(f.counts().T, c.counts())

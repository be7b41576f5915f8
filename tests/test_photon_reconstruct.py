"""Reconstruction from photons: accuracy against the physics, and real captures."""

from __future__ import annotations

import importlib

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
    synthesize_variants,
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


@pytest.mark.parametrize(
    "sensor", [SENSOR, SensorParams.paper_real()], ids=["tabletop", "paper_real"]
)
def test_skipping_the_photons_that_cannot_count_changes_no_number(scene, sensor, monkeypatch):
    """The reconstruction skips photons that cannot count (``_PRUNE``): isolated photons
    in the LMF scores, photons far from every candidate of a 5x5 window in the pooled
    choice, photons beyond the EM's reach. Every output is the same, bit for bit, as
    when every photon is read, over photon budgets, backgrounds, voids and censoring."""
    module = importlib.import_module("spl_al.photon.reconstruct")
    holes = scene.copy()
    holes[np.random.default_rng(0).random(scene.shape) < 0.3] = np.nan
    for depth in (scene, holes):
        for msppp, sbr in ((10.0, 0.2), (2.0, 0.2), (5.0, 1.0), (2.0, 5.0), (0.5, 0.1)):
            ev = simulate_photons(
                PhotonScene(depth), Condition(msppp, sbr, sensor), np.random.default_rng(1)
            )
            for method, censor in (("pooled", False), ("lmf", True), ("pooled", True)):
                out = {}
                for prune in (False, True):
                    monkeypatch.setattr(module, "_PRUNE", prune)
                    out[prune] = reconstruct(ev, ev.shape, sensor, method=method, censor=censor)
                for field, a, b in zip(out[True]._fields, out[False], out[True], strict=True):
                    assert np.array_equal(a, b, equal_nan=True), (msppp, sbr, method, field)


def test_shifted_views_are_the_shifted_copies():
    """The pooled choice and the 3x3 filters read shifted images as views of one padded
    copy (``_at``), the same values as ``_shift``'s copies."""
    module = importlib.import_module("spl_al.photon.reconstruct")
    rng = np.random.default_rng(0)
    ints = rng.integers(-1, 50, (5, 7))
    floats = np.where(rng.random((5, 7)) < 0.2, np.nan, rng.normal(size=(5, 7)))
    for image, fill in ((ints, -1), (floats, np.nan), (floats, 0.0)):
        padded = module._padded(image, fill, 2)
        for dy in range(-2, 3):
            for dx in range(-2, 3):
                view = module._at(padded, 2, dy, dx)
                assert view.dtype == image.dtype
                np.testing.assert_array_equal(view, module._shift(image, dy, dx, fill))


def test_synthesize_variants_are_each_frames_own(scene):
    """A frame's variants come from its own generator: the same alone or in a batch,
    the same as ``synthesize_variant`` on the whole frame (the crop changes nothing),
    all-void for a frame without returns."""
    conditions = [(5.0, 1.0), (2.0, 0.2)]
    shifted = np.roll(scene, 3, axis=1)
    shifted[:, :10] = np.nan  # a frame whose returns fill part of it
    empty = np.full(scene.shape, np.nan)
    depth = np.stack([scene, shifted, empty])
    valid = np.isfinite(depth)

    def rngs(ids):
        return [np.random.default_rng([7, i]) for i in ids]

    batch = synthesize_variants(depth, valid, conditions, rng=rngs(range(3)), sensor=SENSOR)
    assert batch.shape == (3, 2, *scene.shape) and batch.dtype == np.float32
    alone = synthesize_variants(depth[1:2], valid[1:2], conditions, rng=rngs([1]), sensor=SENSOR)
    np.testing.assert_array_equal(batch[1:2], alone)
    assert np.isnan(batch[2]).all()
    rng = np.random.default_rng([7, 1])
    for j, (msppp, sbr) in enumerate(conditions):
        whole = synthesize_variant(
            PhotonScene(np.where(valid[1], depth[1], 0.0), None, valid[1]),
            Condition(msppp, sbr, SENSOR),
            rng,
        )
        np.testing.assert_array_equal(batch[1, j], whole.astype(np.float32))
    with pytest.raises(ValueError, match="reach"):
        synthesize_variants(depth[:1] * 100, valid[:1], conditions, rng=rngs([0]), sensor=SENSOR)


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

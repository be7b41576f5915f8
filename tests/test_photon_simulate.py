"""Statistics of the photon simulator against docs/method.md section 2 (Algorithm 1)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.photon_scenes import disc_scene
from scipy import stats

from spl_al.photon import Condition, PhotonScene, SensorParams, histogram, simulate_photons
from spl_al.photon.reference import simulate_photons_loop

SENSOR = SensorParams.tabletop()


def two_tone_reflectance(shape):
    """Left half 1, right half 3: unit-mean normalised to 0.5 and 1.5."""
    refl = np.ones(shape)
    refl[:, shape[1] // 2 :] = 3.0
    return refl


def test_signal_and_background_rates_follow_reflectance_and_sbr(scene):
    rng = np.random.default_rng(1)
    msppp, sbr = 5.0, 0.5
    refl = two_tone_reflectance(scene.shape)
    a = refl / refl.mean()
    sig = np.zeros(scene.size)
    bkg = np.zeros(scene.size)
    n_frames = 8
    for _ in range(n_frames):
        ev = simulate_photons(
            PhotonScene(scene, reflectance=refl), Condition(msppp, sbr, SENSOR), rng
        )
        sig += np.bincount(ev.pixel[ev.is_signal], minlength=scene.size)
        bkg += np.bincount(ev.pixel[~ev.is_signal], minlength=scene.size)
    sig, bkg = sig / n_frames, bkg / n_frames
    for tone in (0.5, 1.5):
        px = a.ravel() == tone
        expected = msppp * tone
        assert sig[px].mean() == pytest.approx(
            expected, abs=5 * np.sqrt(expected / px.sum() / n_frames)
        )
        # Background is the expected mean signal / sbr for every pixel, whatever its A.
        expected_bkg = msppp / sbr
        tol = 5 * np.sqrt(expected_bkg / px.sum() / n_frames)
        assert bkg[px].mean() == pytest.approx(expected_bkg, abs=tol)


def test_total_photons_per_frame(scene):
    rng = np.random.default_rng(2)
    msppp, sbr = 3.0, 2.0
    valid = scene < 5.0  # only the disc returns light
    totals = [
        len(simulate_photons(PhotonScene(scene, valid=valid), Condition(msppp, sbr, SENSOR), rng))
        for _ in range(20)
    ]
    expected = msppp * valid.sum() * (1 + 1 / sbr)
    assert np.mean(totals) == pytest.approx(expected, abs=5 * np.sqrt(expected / 20))


def test_invalid_pixels_detect_nothing(scene):
    valid = scene < 5.0
    ev = simulate_photons(
        PhotonScene(scene, valid=valid), Condition(10.0, 0.5, SENSOR), np.random.default_rng(3)
    )
    assert valid.ravel()[ev.pixel].all()


def test_background_bins_are_uniform(scene):
    ev = simulate_photons(PhotonScene(scene), Condition(5.0, 0.1, SENSOR), np.random.default_rng(4))
    counts = np.bincount(ev.bin[~ev.is_signal], minlength=SENSOR.n_bins)
    assert counts.sum() > 150_000
    assert stats.chisquare(counts).pvalue > 1e-3
    assert ev.bin.min() >= 0 and ev.bin.max() <= SENSOR.t_max


def test_signal_bins_centre_on_t_obs_with_sigma_spread():
    depth = np.full((64, 64), 6.0)
    sensor = SensorParams(bin_width_s=80e-12, pulse_sigma_s=3 * 80e-12, n_bins=1024)
    ev = simulate_photons(
        PhotonScene(depth), Condition(20.0, np.inf, sensor), np.random.default_rng(5)
    )
    t_obs = sensor.depth_to_bin(6.0)
    residual = ev.bin[ev.is_signal] - t_obs
    assert residual.size > 70_000
    assert abs(residual.mean()) < 0.02
    # Rounding to bins adds the variance of a uniform on one bin, 1/12.
    assert residual.std() == pytest.approx(np.sqrt(3.0**2 + 1 / 12), rel=0.01)


@pytest.mark.parametrize("edge", ["near", "far"])
def test_signal_bins_clip_at_both_ends(edge):
    sensor = SensorParams(bin_width_s=80e-12, pulse_sigma_s=2 * 80e-12, n_bins=256)
    depth_m = 0.0 if edge == "near" else sensor.max_depth_m
    depth = np.full((32, 32), depth_m)
    ev = simulate_photons(
        PhotonScene(depth), Condition(20.0, np.inf, sensor), np.random.default_rng(6)
    )
    bins = ev.bin[ev.is_signal]
    assert bins.min() >= 0 and bins.max() <= sensor.t_max
    edge_bin = 0 if edge == "near" else sensor.t_max
    # All that rounds past the edge piles up on it: P(round(sigma z) <= 0) = Phi(0.5 / sigma).
    expected = stats.norm.cdf(0.5 / sensor.sigma_bins)
    assert np.mean(bins == edge_bin) == pytest.approx(expected, abs=0.01)


def test_fraction_of_empty_pixels(scene):
    rng = np.random.default_rng(7)
    msppp, sbr = 1.0, 1.5
    refl = two_tone_reflectance(scene.shape)
    a = refl / refl.mean()
    empty = np.mean(
        [
            np.mean(
                simulate_photons(
                    PhotonScene(scene, reflectance=refl), Condition(msppp, sbr, SENSOR), rng
                ).counts()
                == 0
            )
            for _ in range(10)
        ]
    )
    expected = np.mean(np.exp(-msppp * (a + 1 / sbr)))
    assert empty == pytest.approx(expected, abs=0.005)


def test_noise_free_limit_returns_t_obs_exactly(scene):
    sensor = SensorParams(bin_width_s=80e-12, pulse_sigma_s=0.0, n_bins=1024)
    ev = simulate_photons(
        PhotonScene(scene), Condition(4.0, np.inf, sensor), np.random.default_rng(8)
    )
    assert ev.is_signal.all()
    np.testing.assert_array_equal(ev.bin, sensor.depth_to_bin(scene).ravel()[ev.pixel])


def test_same_seed_same_photons_and_different_seed_differs(scene):
    a = simulate_photons(PhotonScene(scene), Condition(5.0, 1.0, SENSOR), np.random.default_rng(9))
    b = simulate_photons(PhotonScene(scene), Condition(5.0, 1.0, SENSOR), np.random.default_rng(9))
    c = simulate_photons(PhotonScene(scene), Condition(5.0, 1.0, SENSOR), np.random.default_rng(10))
    np.testing.assert_array_equal(a.pixel, b.pixel)
    np.testing.assert_array_equal(a.bin, b.bin)
    assert len(a) != len(c) or not np.array_equal(a.bin, c.bin)


def test_vectorised_matches_the_loop_reference_statistically():
    depth = disc_scene(24, 24)
    refl = two_tone_reflectance(depth.shape)
    msppp, sbr = 4.0, 0.8
    fast, slow = [], []
    for seed in range(12):
        fast.append(
            simulate_photons(
                PhotonScene(depth, reflectance=refl),
                Condition(msppp, sbr, SENSOR),
                np.random.default_rng(seed),
            )
        )
        slow.append(
            simulate_photons_loop(
                PhotonScene(depth, reflectance=refl),
                Condition(msppp, sbr, SENSOR),
                np.random.default_rng(seed),
            )
        )

    def summary(frames):
        t_obs = SENSOR.depth_to_bin(depth).ravel()
        sig = np.concatenate([f.bin[f.is_signal] - t_obs[f.pixel[f.is_signal]] for f in frames])
        bkg = np.concatenate([f.bin[~f.is_signal] for f in frames])
        per_pixel = np.mean(
            [np.bincount(f.pixel[f.is_signal], minlength=depth.size) for f in frames], 0
        )
        return sig, bkg, per_pixel

    sig_f, bkg_f, pp_f = summary(fast)
    sig_s, bkg_s, pp_s = summary(slow)
    n_sig = msppp * depth.size * 12
    assert sig_f.size == pytest.approx(n_sig, abs=5 * np.sqrt(n_sig))
    assert sig_s.size == pytest.approx(n_sig, abs=5 * np.sqrt(n_sig))
    assert bkg_f.size == pytest.approx(bkg_s.size, abs=6 * np.sqrt(bkg_s.size))
    assert stats.ks_2samp(sig_f, sig_s).pvalue > 1e-3
    assert stats.ks_2samp(bkg_f, bkg_s).pvalue > 1e-3
    # The per-pixel signal rate follows the reflectance in both.
    assert np.corrcoef(pp_f, pp_s)[0, 1] > 0.9


def test_histogram_is_a_compact_count_cube(scene):
    ev = simulate_photons(
        PhotonScene(scene), Condition(5.0, 1.0, SENSOR), np.random.default_rng(11)
    )
    cube = histogram(ev, scene.shape, SENSOR)
    assert cube.shape == (*scene.shape, SENSOR.n_bins)
    assert cube.dtype == np.uint8
    assert int(cube.sum()) == len(ev)
    np.testing.assert_array_equal(cube.sum(axis=2), ev.counts())
    p = ev.pixel[0]
    assert cube[p // scene.shape[1], p % scene.shape[1], ev.bin[0]] >= 1

"""The fuller sensor model of observed images: each effect does what it says, and off
means Algorithm 1."""

from __future__ import annotations

import numpy as np
import pytest

from spl_al.photon import (
    Condition,
    ObservationModel,
    PhotonScene,
    SensorParams,
    observe_photons,
    reconstruct,
)

SENSOR = SensorParams.tabletop()
OFF = ObservationModel.algorithm1()


def _scene(rows=32, cols=32, depth_m=10.0):
    depth = np.full((rows, cols), np.nan)
    depth[:, : cols // 2] = depth_m  # left half returns, right half is sky
    return depth, np.isfinite(depth)


def _counts(events, shape, signal=None):
    keep = np.ones(len(events), bool) if signal is None else events.is_signal == signal
    return np.bincount(events.pixel[keep], minlength=shape[0] * shape[1]).reshape(shape)


def test_algorithm1_model_has_its_rates_and_no_photon_off_the_returns():
    depth, valid = _scene()
    ev = observe_photons(
        PhotonScene(depth, valid=valid),
        Condition(5.0, 1.0, SENSOR),
        np.random.default_rng(0),
        model=OFF,
    )
    sig, bkg = _counts(ev, depth.shape, True), _counts(ev, depth.shape, False)
    assert sig[:, 16:].sum() == 0 and bkg[:, 16:].sum() == 0
    assert sig[valid].mean() == pytest.approx(5.0, rel=0.05)
    assert bkg[valid].mean() == pytest.approx(5.0, rel=0.05)
    assert OFF.is_algorithm1 and not ObservationModel().is_algorithm1


def test_background_falls_on_every_pixel():
    depth, valid = _scene()
    model = ObservationModel(gain_sigma=0.0, mixed_fraction=0.0)
    ev = observe_photons(
        PhotonScene(depth, valid=valid),
        Condition(4.0, 0.5, SENSOR),
        np.random.default_rng(1),
        model=model,
    )
    bkg = _counts(ev, depth.shape, False)
    # rate mean(msppp A) / sbr = 8 on returning and non-returning pixels alike
    assert bkg[:, 16:].mean() == pytest.approx(8.0, rel=0.05)
    assert bkg[:, :16].mean() == pytest.approx(8.0, rel=0.05)
    assert _counts(ev, depth.shape, True)[:, 16:].sum() == 0


def test_gain_is_unit_mean_and_spreads_counts():
    depth = np.full((64, 64), 10.0)
    valid = np.ones_like(depth, bool)
    rng = np.random.default_rng(2)
    flat = observe_photons(
        PhotonScene(depth, valid=valid), Condition(20.0, np.inf, SENSOR), rng, model=OFF
    )
    gained = observe_photons(
        PhotonScene(depth, valid=valid),
        Condition(20.0, np.inf, SENSOR),
        rng,
        model=ObservationModel(gain_sigma=0.4),
    )
    a, b = _counts(flat, depth.shape), _counts(gained, depth.shape)
    assert b.mean() == pytest.approx(a.mean(), rel=0.03)
    assert b.var() > 2 * a.var()  # Poisson 20 vs Poisson + (0.4 * 20)^2 gain spread


def test_range_falloff_only_for_range_compensated_reflectance():
    depth = np.full((32, 32), 5.0)
    depth[:, 16:] = 10.0
    valid = np.ones_like(depth, bool)
    model = ObservationModel(background_everywhere=False, gain_sigma=0.0, mixed_fraction=0.0)
    rng = np.random.default_rng(3)
    ev = observe_photons(
        PhotonScene(depth, valid=valid),
        Condition(5.0, np.inf, SENSOR),
        rng,
        model=model,
        range_compensated=True,
    )
    sig = _counts(ev, depth.shape, True)
    assert sig[:, :16].mean() / sig[:, 16:].mean() == pytest.approx(4.0, rel=0.1)
    assert sig.mean() == pytest.approx(5.0, rel=0.05), "msppp keeps its meaning"
    plain = observe_photons(
        PhotonScene(depth, valid=valid),
        Condition(5.0, np.inf, SENSOR),
        rng,
        model=model,
        range_compensated=False,
    )
    sig = _counts(plain, depth.shape, True)
    assert sig[:, :16].mean() / sig[:, 16:].mean() == pytest.approx(1.0, rel=0.1)


def test_mixed_pixels_return_photons_of_both_surfaces_at_an_edge():
    depth = np.full((32, 32), 10.0)
    depth[:, 16:] = 12.0
    valid = np.ones_like(depth, bool)
    model = ObservationModel(background_everywhere=False, gain_sigma=0.0, mixed_fraction=0.4)
    ev = observe_photons(
        PhotonScene(depth, valid=valid),
        Condition(50.0, np.inf, SENSOR),
        np.random.default_rng(4),
        model=model,
    )
    near_bin, far_bin = SENSOR.depth_to_bin(10.0), SENSOR.depth_to_bin(12.0)
    col = ev.pixel % 32
    edge_far = (col == 16) & (np.abs(ev.bin - near_bin) < 4 * SENSOR.sigma_bins)
    # the first far column gets f/4 of its left neighbour's photons from the near surface
    assert edge_far.sum() / 32 == pytest.approx(50.0 * 0.1, rel=0.2)
    inside = (col == 20) & (np.abs(ev.bin - near_bin) < 4 * SENSOR.sigma_bins)
    assert inside.sum() == 0
    assert ((col == 16) & (np.abs(ev.bin - far_bin) < 4 * SENSOR.sigma_bins)).sum() > 0


def test_dead_time_drops_photons_close_after_another_in_the_same_cycle():
    depth = np.full((8, 8), 10.0)
    valid = np.ones_like(depth, bool)
    base = dict(background_everywhere=False, gain_sigma=0.0, mixed_fraction=0.0)
    rng = np.random.default_rng(5)
    free = observe_photons(
        PhotonScene(depth, valid=valid),
        Condition(200.0, np.inf, SENSOR),
        rng,
        model=ObservationModel(**base),
    )
    piled = observe_photons(
        PhotonScene(depth, valid=valid),
        Condition(200.0, np.inf, SENSOR),
        rng,
        model=ObservationModel(**base, dead_time_bins=50, cycles=20),
    )
    assert len(piled) < 0.5 * len(free), "10 photons per cycle in one peak: most are lost"
    assert ObservationModel().dead_time_bins == 0, "off by default"


def test_censoring_voids_what_only_background_reached():
    depth, valid = _scene(32, 32)
    model = ObservationModel(gain_sigma=0.0, mixed_fraction=0.0)
    ev = observe_photons(
        PhotonScene(depth, valid=valid),
        Condition(5.0, 0.5, SENSOR),
        np.random.default_rng(6),
        model=model,
    )
    loose = reconstruct(ev, depth.shape, SENSOR)
    strict = reconstruct(ev, depth.shape, SENSOR, censor=True)
    assert loose.valid[:, 18:].mean() > 0.9, "background alone gives random depths"
    assert strict.valid[:, 18:].mean() < 0.1
    assert strict.valid[:, :14].mean() > 0.95
    ok = strict.valid[:, :14]
    assert np.median(np.abs(strict.depth_m[:, :14][ok] - 10.0)) < 0.05


def test_bad_settings_are_one_clear_error():
    for bad, match in (
        ({"gain_sigma": -1}, "gain_sigma"),
        ({"mixed_fraction": 1.0}, "mixed_fraction"),
        ({"dead_time_bins": -2}, "dead_time_bins"),
        ({"background_everywhere": "yes"}, "background_everywhere"),
    ):
        with pytest.raises(ValueError, match=match):
            ObservationModel(**bad)
    with pytest.raises(ValueError, match="unknown observation keys"):
        ObservationModel.from_dict({"gain": 1})

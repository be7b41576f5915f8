"""SSPI with the published weights (skipped unless $SPL_AL_SSPI_WEIGHTS names them)."""

from __future__ import annotations

import numpy as np

from spl_al.photon import SensorParams, load_mat, reconstruct, simulate_photons
from spl_al.photon.demo import demo_scene


def test_simulated_scene_at_a_good_condition(sspi_weights):
    sensor = SensorParams.tabletop()  # 80 ps bins: the weights' simulations
    depth, refl = demo_scene()
    ev = simulate_photons(depth, refl, None, 5.0, 1.0, sensor, np.random.default_rng(0))
    rec = reconstruct(ev, depth.shape, sensor, method="sspi", weights=sspi_weights)
    err_m = np.abs(rec.depth_m - depth)
    assert rec.valid.mean() > 0.99
    assert np.nanmean(err_m <= 0.1) > 0.95
    assert np.nanmedian(err_m) < 0.03


def test_real_capture_shows_the_wall_at_67_m(sspi_weights, real_captures):
    capture = real_captures / "car_20.mat"
    events = load_mat(capture if capture.exists() else sorted(real_captures.glob("*.mat"))[0])
    rec = reconstruct(events, events.shape, SensorParams.ugv45m(), "sspi", weights=sspi_weights)
    pooled = reconstruct(events, events.shape, SensorParams.ugv45m(), "pooled")
    assert rec.valid.mean() > 0.95
    assert 66.0 < np.nanmedian(rec.depth_m) < 68.0  # most of the frame is the wall
    both = rec.valid & pooled.valid
    assert np.mean(np.abs(rec.depth_m - pooled.depth_m)[both] <= 0.3) > 0.9

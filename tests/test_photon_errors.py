"""Every malformed input to the photon engine raises one clear ValueError naming it."""

from __future__ import annotations

import numpy as np
import pytest

from spl_al.photon import (
    Condition,
    PhotonScene,
    SensorParams,
    histogram,
    load_mat,
    reconstruct,
    simulate_photons,
    synthesize_variant,
)

SENSOR = SensorParams.tabletop()
RNG = np.random.default_rng(0)


def simulate(depth=None, reflectance=None, valid=None, msppp=5.0, sbr=1.0, sensor=SENSOR):
    depth = np.full((8, 8), 3.0) if depth is None else depth
    return simulate_photons(
        PhotonScene(depth, reflectance=reflectance, valid=valid), Condition(msppp, sbr, sensor), RNG
    )


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"depth": np.full(8, 3.0)}, "depth_m must be a 2-D image"),
        ({"valid": np.ones((4, 4), bool)}, "valid has shape"),
        ({"reflectance": np.ones((8, 9))}, "reflectance has shape"),
        (
            {"depth": np.where(np.eye(8) > 0, np.nan, 3.0), "valid": np.ones((8, 8), bool)},
            "NaN or inf",
        ),
        (
            {"depth": np.where(np.eye(8) > 0, np.inf, 3.0), "valid": np.ones((8, 8), bool)},
            "NaN or inf",
        ),
        ({"depth": np.full((8, 8), -1.0)}, "negative depths"),
        ({"msppp": 0.0}, "msppp must be"),
        ({"msppp": -2.0}, "msppp must be"),
        ({"msppp": np.nan}, "msppp must be"),
        ({"sbr": 0.0}, "sbr must be"),
        ({"sbr": -1.0}, "sbr must be"),
        ({"depth": np.full((8, 8), 50.0)}, r"beyond the sensor's reach of 12\.2"),
        ({"valid": np.zeros((8, 8), bool)}, "valid marks no pixel"),
        ({"reflectance": np.zeros((8, 8))}, "reflectance is zero"),
        ({"reflectance": -np.ones((8, 8))}, "reflectance must be finite and >= 0"),
        ({"valid": np.full((8, 8), 2)}, "valid must be a boolean mask"),
    ],
)
def test_bad_scene_input_is_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        simulate(**kwargs)


def test_nan_on_invalid_pixels_is_fine():
    depth = np.full((8, 8), 3.0)
    depth[0] = np.nan
    events = simulate(depth=depth)  # valid=None: finite depths are the valid set
    assert (events.pixel >= 8).all()


def test_synthesize_variant_checks_like_simulate():
    with pytest.raises(ValueError, match="msppp must be"):
        synthesize_variant(PhotonScene(np.full((8, 8), 3.0)), Condition(0.0, 1.0, SENSOR), RNG)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"bin_width_s": 0.0}, "bin_width_s must be > 0"),
        ({"pulse_sigma_s": -1e-12}, "pulse_sigma_s must be >= 0"),
        ({"n_bins": 1}, "n_bins must be an integer >= 2"),
        ({"n_bins": 10.5}, "n_bins must be an integer >= 2"),
    ],
)
def test_bad_sensor_is_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        SensorParams(**kwargs)


def test_reconstruct_and_histogram_refuse_mismatched_input():
    events = simulate()
    with pytest.raises(ValueError, match="method must be one of"):
        reconstruct(events, (8, 8), SENSOR, method="ml")
    with pytest.raises(ValueError, match="does not match the events' frame shape"):
        reconstruct(events, (4, 16), SENSOR)
    short = SensorParams(n_bins=16)
    with pytest.raises(ValueError, match=r"outside 0\.\.15"):
        reconstruct(events, (8, 8), short)
    with pytest.raises(ValueError, match="beyond the sensor's T_max"):
        histogram(events, (8, 8), short)


def test_no_photons_gives_all_voids():
    empty = simulate()
    empty = type(empty)(empty.pixel[:0], empty.bin[:0], empty.is_signal[:0], empty.shape)
    rec = reconstruct(empty, (8, 8), SENSOR)
    assert not rec.valid.any() and np.isnan(rec.depth_m).all()


def test_load_mat_names_the_file_and_the_problem(tmp_path):
    broken = tmp_path / "broken.mat"
    broken.write_bytes(b"not a mat file at all")
    with pytest.raises(ValueError, match=r"broken\.mat: not a readable MATLAB"):
        load_mat(broken)
    from scipy import io as sio
    from scipy import sparse

    other = tmp_path / "other.mat"
    sio.savemat(other, {"photons": sparse.csc_matrix(np.ones((16, 4)))})
    with pytest.raises(
        ValueError, match=r"no sparse matrix 'spad'; sparse matrices found: \['photons'\]"
    ):
        load_mat(other)
    with pytest.raises(ValueError, match="expected 4096 pixels"):
        load_mat(other, key="photons")
    events = load_mat(other, key="photons", shape=(4, 4))
    assert len(events) == 64 and events.counts().sum() == 64

"""`python -m spl_al.photon reconstruct`: a capture in, the release layout out, with the
sensor and the conditions read off the photons."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.photon_captures import simulate_capture, write_cube_npz, write_timestamps_mat

from spl_al.photon import SensorParams
from spl_al.photon.__main__ import main
from spl_al.photon.release import drop_isolated

ROWS, COLS, SKY_ROWS = 32, 40, 8


def _scene():
    """A wall at ~60 m with a car at 52 m; the top rows are sky (no return)."""
    yy, xx = np.mgrid[:ROWS, :COLS]
    depth = 60.0 + 0.05 * xx
    depth[(yy > 18) & (xx > 8) & (xx < 28)] = 52.0
    return depth, yy < SKY_ROWS


@pytest.fixture(scope="module")
def timestamps(tmp_path_factory):
    """Picosecond timestamps at 4 ps resolution in a 100 ns gate, 520 ps jitter."""
    depth, sky = _scene()
    sensor = SensorParams(bin_width_s=4e-12, pulse_sigma_s=520e-12, n_bins=110_000)
    events = simulate_capture(depth, 5.0, 0.5, sensor, seed=7, sky=sky)
    path = tmp_path_factory.mktemp("ts") / "scan.mat"
    return write_timestamps_mat(path, events, bin_width_ps=4), depth, sky


def test_timestamps_reconstruct_cleanly_with_no_options(timestamps, tmp_path, capsys):
    path, depth, sky = timestamps
    out = tmp_path / "scan.npz"
    assert main(["reconstruct", str(path), str(out)]) == 0
    line = capsys.readouterr().out
    assert line.count("\n") == 1 and "MSPPP" in line and f"wrote {out}" in line
    with np.load(out) as z:
        keys = {"depth_ssp", "intensity", "msppp", "sbr", "pulse_sigma_s", "bin_width_s"}
        assert keys <= set(z.files)
        got = z["depth_ssp"]
        # sky and beyond range: voids (0), not random depths; the sky's last row is
        # left out, its 3x3 windows hold the returns of the scene below
        assert np.mean(got[: SKY_ROWS - 1] == 0) >= 0.97
        scene = ~sky
        assert np.mean(got[scene] > 0) >= 0.98
        valid = got > 0
        assert np.median(np.abs(got[valid & scene] - depth[valid & scene])) < 0.05
        assert float(z["pulse_sigma_s"]) == pytest.approx(520e-12, rel=0.15)
        assert float(z["bin_width_s"]) == pytest.approx(4e-12)
        # simulated: 5 signal photons per scene pixel, background 10 per pixel everywhere
        scene_fraction = 1 - SKY_ROWS / ROWS
        assert float(z["msppp"]) == pytest.approx(5.0 * scene_fraction, rel=0.15)
        assert float(z["sbr"]) == pytest.approx(5.0 * scene_fraction / 10.0, rel=0.15)
        assert np.all(z["intensity"][got == 0] == 0)


def test_given_pulse_sigma_is_used(timestamps, tmp_path, capsys):
    path, _, _ = timestamps
    out = tmp_path / "given.npz"
    assert main(["reconstruct", str(path), str(out), "--pulse-sigma-ps", "500"]) == 0
    assert "pulse sigma 500 ps," in capsys.readouterr().out
    with np.load(out) as z:
        assert float(z["pulse_sigma_s"]) == pytest.approx(500e-12)
        assert np.isnan(float(z["pulse_sigma_stderr_s"]))


def test_cube_with_options_and_bad_output(tmp_path, capsys):
    depth, _ = _scene()
    sensor = SensorParams(bin_width_s=100e-12, pulse_sigma_s=520e-12, n_bins=5000)
    events = simulate_capture(depth, 10.0, 2.0, sensor, seed=2)
    cube = write_cube_npz(tmp_path / "cube.npz", events, sensor, time_first=True)
    out = tmp_path / "out.npz"
    assert main(["reconstruct", str(cube), str(out), "--format", "cube"]) == 0
    with np.load(out) as z:
        assert np.median(np.abs(z["depth_ssp"] - depth)) < 0.05
    assert main(["reconstruct", str(cube), str(tmp_path / "out.txt")]) == 2
    assert "OUT must be a .npz file" in capsys.readouterr().err
    assert not (tmp_path / "out.txt").exists()
    assert main(["reconstruct", str(tmp_path / "none.mat"), str(out)]) == 2
    assert "no such capture file" in capsys.readouterr().err


def test_real_pictures_take_any_format(timestamps, tmp_path, capsys):
    path, _, _ = timestamps
    png = tmp_path / "scan.png"
    assert main(["--real", str(path), str(png)]) == 0
    assert png.stat().st_size > 10_000
    assert "timestamps_mat: 32x40 pixels" in capsys.readouterr().out


def test_drop_isolated_keeps_surfaces_and_drops_lone_returns():
    depth = np.full((6, 6), np.nan)
    depth[1:4, 1:4] = 10.0  # a 3x3 surface: every pixel has >= 3 close neighbours
    depth[5, 5] = 30.0  # a lone return
    depth[0, 5], depth[1, 5] = 20.0, 20.0  # a pair: one close neighbour each
    out = drop_isolated(depth, 0.5)
    assert np.isfinite(out[1:4, 1:4]).all()
    assert np.isnan(out[5, 5]) and np.isnan(out[0, 5]) and np.isnan(out[1, 5])


def test_ugv45m_reconstructs_to_the_known_scene(ugv45m_dir, tmp_path):
    out = tmp_path / "car_20.npz"
    assert main(["reconstruct", str(ugv45m_dir / "car_20.mat"), str(out)]) == 0
    with np.load(out) as z:
        d = z["depth_ssp"]
        # a wall at ~67 m fills most of the frame (README of the captures)
        assert np.mean(np.abs(d - 66.8) < 1.0) > 0.5
        assert 300e-12 < float(z["pulse_sigma_s"]) < 900e-12
        assert float(z["bin_width_s"]) == pytest.approx(100e-12)

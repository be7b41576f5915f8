"""load_capture: every format gives back the photons it was written with, its timing,
and one clear error for each kind of bad file."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from helpers.photon_captures import (
    pixel_bin_counts,
    simulate_capture,
    timestamp_cells,
    write_cube_h5,
    write_cube_npz,
    write_ptu,
    write_timestamps_mat,
    write_v73_cells,
)
from helpers.photon_scenes import disc_scene

from spl_al.photon import SensorParams
from spl_al.photon.io import load_capture, load_mat

SENSOR = SensorParams(bin_width_s=80e-12, pulse_sigma_s=160e-12, n_bins=256)


@pytest.fixture(scope="module")
def events():
    depth = disc_scene(12, 16, near_m=1.0, far_m=2.0)
    return simulate_capture(depth, 5.0, 1.0, SENSOR, seed=3)


def _same_photons(a, b):
    assert a.shape == b.shape
    np.testing.assert_array_equal(pixel_bin_counts(a), pixel_bin_counts(b))


def test_timestamps_mat_bins_at_native_resolution(events, tmp_path):
    path = write_timestamps_mat(tmp_path / "ts.mat", events, bin_width_ps=80)
    cap = load_capture(path)
    assert cap.format == "timestamps_mat" and cap.shape == (12, 16)
    assert cap.bin_width_s == pytest.approx(80e-12)
    # without a gate the capture starts at the earliest photon's bin
    first = int(events.bin.min())
    assert cap.gate_start_s == pytest.approx(first * 80e-12)
    shifted = type(events)(events.pixel, events.bin - first, events.is_signal, events.shape)
    _same_photons(cap.events, shifted)


def test_timestamps_mat_with_gate_and_given_bin_width(events, tmp_path):
    gate = (1_000_000, 1_000_000 + 256 * 80)  # a gate 1 us after the pulse (150 m)
    path = write_timestamps_mat(tmp_path / "ts.mat", events, bin_width_ps=80, gate_ps=gate)
    cap = load_capture(path)
    assert cap.gate_start_s == pytest.approx(1e-6) and cap.n_bins == 257
    assert cap.gate_depth_m == pytest.approx(149.896229, rel=1e-6)
    _same_photons(cap.events, events)
    wide = load_capture(path, bin_width_s=160e-12)
    np.testing.assert_array_equal(np.sort(wide.events.bin), np.sort(events.bin // 2))
    ns = load_capture(path, time_unit="ns", bin_width_s=80e-12)  # times read as ns
    assert ns.bin_width_s == pytest.approx(80e-12) and ns.gate_start_s == pytest.approx(1e-3)


def test_v73_cell_array_reads_like_v5(events, tmp_path):
    cells = timestamp_cells(events, 80)
    cap = load_capture(write_v73_cells(tmp_path / "v73.mat", cells))
    v5 = load_capture(write_timestamps_mat(tmp_path / "v5.mat", events, bin_width_ps=80))
    assert cap.format == "timestamps_mat" and cap.shape == v5.shape
    _same_photons(cap.events, v5.events)


@pytest.mark.parametrize("time_first", [False, True])
def test_cube_npz_either_axis_order(events, tmp_path, time_first):
    cap = load_capture(write_cube_npz(tmp_path / "c.npz", events, SENSOR, time_first=time_first))
    assert cap.format == "cube" and cap.n_bins == 256 and cap.bin_width_s == pytest.approx(80e-12)
    _same_photons(cap.events, events)


def test_cube_hdf5_and_npy(events, tmp_path):
    cap = load_capture(write_cube_h5(tmp_path / "c.h5", events, SENSOR))
    _same_photons(cap.events, events)
    assert cap.bin_width_s == pytest.approx(80e-12)
    from spl_al.photon import histogram

    np.save(tmp_path / "c.npy", histogram(events, events.shape, SENSOR))
    with pytest.raises(ValueError, match="states no bin width"):
        load_capture(tmp_path / "c.npy")
    _same_photons(load_capture(tmp_path / "c.npy", bin_width_s=80e-12).events, events)


def test_cube_in_mat(events, tmp_path):
    from scipy import io as sio

    from spl_al.photon import histogram

    cube = histogram(events, events.shape, SENSOR).astype(np.float64)
    sio.savemat(tmp_path / "cube.mat", {"hist": cube, "bin_width_ps": 80.0})
    cap = load_capture(tmp_path / "cube.mat")
    assert cap.format == "cube"
    _same_photons(cap.events, events)


def test_ptu_image_written_with_ptufile(events, tmp_path):
    cap = load_capture(write_ptu(tmp_path / "scan.ptu", events, SENSOR))
    assert cap.format == "ptu" and cap.shape == (12, 16) and cap.n_frames == 1
    assert cap.bin_width_s == pytest.approx(80e-12)
    _same_photons(cap.events, events)
    with pytest.raises(ValueError, match="channel 1 does not exist"):
        load_capture(tmp_path / "scan.ptu", channel=1)


def test_sparse_mat_states_its_timing(events, tmp_path):
    from scipy import io as sio
    from scipy import sparse

    rows, cols = events.shape
    r, c = divmod(events.pixel.astype(np.int64), cols)
    matrix = sparse.coo_matrix(
        (np.ones(len(events)), (c * rows + r, events.bin)), shape=(rows * cols, 256)
    ).tocsc()
    sio.savemat(tmp_path / "s.mat", {"counts": matrix})
    with pytest.raises(ValueError, match="not a square frame"):
        load_capture(tmp_path / "s.mat")
    with pytest.raises(ValueError, match="states no bin width"):
        load_capture(tmp_path / "s.mat", shape=(12, 16))
    sio.savemat(tmp_path / "s.mat", {"counts": matrix, "bin_width_ps": 80.0})
    cap = load_capture(tmp_path / "s.mat", shape=(12, 16))
    assert cap.format == "sparse_mat" and cap.bin_width_s == pytest.approx(80e-12)
    _same_photons(cap.events, events)


# ------------------------------------------------------------------ bad input


def test_truncated_and_unknown_files(events, tmp_path):
    path = write_timestamps_mat(tmp_path / "ts.mat", events, bin_width_ps=80)
    cut = tmp_path / "cut.mat"
    cut.write_bytes(path.read_bytes()[:400])
    with pytest.raises(ValueError, match=r"cut\.mat: not a readable MATLAB"):
        load_capture(cut)
    npz = write_cube_npz(tmp_path / "c.npz", events, SENSOR)
    (tmp_path / "cut.npz").write_bytes(npz.read_bytes()[:200])
    with pytest.raises(ValueError, match=r"cut\.npz: cannot be read"):
        load_capture(tmp_path / "cut.npz")
    ptu = write_ptu(tmp_path / "scan.ptu", events, SENSOR)
    (tmp_path / "cut.ptu").write_bytes(ptu.read_bytes()[:300])
    with pytest.raises(ValueError, match=r"cut\.ptu: not a readable PicoQuant PTU"):
        load_capture(tmp_path / "cut.ptu")
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(ValueError, match="not a capture file this reader knows; supported"):
        load_capture(tmp_path / "notes.txt")
    with pytest.raises(ValueError, match="no such capture file"):
        load_capture(tmp_path / "missing.mat")


def test_mat_without_photons_lists_what_it_found(tmp_path):
    from scipy import io as sio

    sio.savemat(tmp_path / "x.mat", {"depth": np.zeros((4, 4)), "name": "scan"})
    with pytest.raises(ValueError, match=r"no photon data found among its variables \(depth"):
        load_capture(tmp_path / "x.mat")


def test_non_numeric_cell_names_the_cell(events, tmp_path):
    from scipy import io as sio

    cells = timestamp_cells(events, 80)
    cells[2, 5] = "oops"
    sio.savemat(tmp_path / "bad.mat", {"photons": cells})
    with pytest.raises(ValueError, match=r"bad\.mat: photons\{3,6\} holds dtype <U4"):
        load_capture(tmp_path / "bad.mat")


def test_times_outside_the_gate(events, tmp_path):
    path = write_timestamps_mat(tmp_path / "g.mat", events, bin_width_ps=80, gate_ps=(0, 100 * 80))
    with pytest.raises(
        ValueError, match=r"g\.mat: \d+ of \d+ arrival times in photons lie outside"
    ):
        load_capture(path)


def test_cube_with_ambiguous_axes(tmp_path):
    np.savez(tmp_path / "sq.npz", counts=np.zeros((32, 8, 32), np.uint8), bin_width_ps=80.0)
    with pytest.raises(ValueError, match=r"cannot tell which axis of counts \(32x8x32\) is time"):
        load_capture(tmp_path / "sq.npz")
    cap = load_capture(tmp_path / "sq.npz", time_axis=2)
    assert cap.shape == (32, 8) and cap.n_bins == 32


def test_ptu_without_image_markers(events, tmp_path):
    raw = bytearray(write_ptu(tmp_path / "scan.ptu", events, SENSOR).read_bytes())
    at = raw.find(b"Measurement_SubMode")  # tag: 32-byte name, index, type, then the value
    raw[at + 40 : at + 48] = struct.pack("<q", 0)
    (tmp_path / "point.ptu").write_bytes(bytes(raw))
    with pytest.raises(ValueError, match=r"point\.ptu: a PTU .* without image"):
        load_capture(tmp_path / "point.ptu")


def test_negative_counts_in_a_cube(tmp_path):
    cube = np.zeros((4, 4, 64), np.int16)
    cube[1, 1, 5] = -2
    np.savez(tmp_path / "neg.npz", counts=cube, bin_width_ps=80.0)
    with pytest.raises(ValueError, match=r"neg\.npz: counts: photon counts must be non-negative"):
        load_capture(tmp_path / "neg.npz")


# ------------------------------------------------------------------ real captures


def test_ugv45m_reads_through_load_capture(ugv45m_dir):
    path = ugv45m_dir / "car_20.mat"
    cap = load_capture(path)
    assert cap.format == "sparse_mat" and cap.shape == (64, 64)
    assert cap.n_bins == 10_000 and cap.bin_width_s == pytest.approx(100e-12)
    assert any("ugv45m layout" in note for note in cap.notes)
    _same_photons(cap.events, load_mat(path))


def test_stated_bin_width_wins_over_the_option(events, tmp_path):
    path = write_cube_npz(tmp_path / "c.npz", events, SENSOR)  # states 80 ps
    assert load_capture(path, bin_width_s=16e-12).bin_width_s == pytest.approx(80e-12)


def test_cell_array_of_names_beside_a_cube_is_metadata(events, tmp_path):
    from scipy import io as sio

    from spl_al.photon import histogram

    names = np.empty((1, 1), dtype=object)
    names[0, 0] = "car"
    cube = histogram(events, events.shape, SENSOR).astype(np.float64)
    sio.savemat(tmp_path / "cube.mat", {"hist": cube, "names": names, "bin_width_ps": 80.0})
    cap = load_capture(tmp_path / "cube.mat")
    assert cap.format == "cube"
    _same_photons(cap.events, events)

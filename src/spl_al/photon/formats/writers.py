"""Writers of the capture formats ``spl_al.photon.io`` reads, for simulated captures.

Tests and benchmarks write simulated photons as a lab's file would hold them: a
MATLAB v5 cell array of picosecond timestamps, a sparse pixels x bins matrix, a count
cube in ``.npz`` or HDF5, and a PicoQuant PTU image (written by ``ptufile``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.photon.events import PhotonEvents, histogram
from spl_al.photon.sensor import SensorParams


def timestamp_cells(events: PhotonEvents, bin_width_ps: int, gate_start_ps: int = 0):
    """(H, W) object array of int64 arrival times in ps, one array per pixel."""
    rows, cols = events.shape
    times = gate_start_ps + events.bin.astype(np.int64) * bin_width_ps
    order = np.argsort(events.pixel, kind="stable")
    split = np.cumsum(np.bincount(events.pixel, minlength=rows * cols))[:-1]
    cells = np.empty((rows, cols), dtype=object)
    for p, chunk in enumerate(np.split(times[order], split)):
        cells[divmod(p, cols)] = chunk.reshape(-1, 1).astype(np.float64)
    return cells


def write_timestamps_mat(path, events, *, bin_width_ps: int, gate_ps=None, key="photons"):
    """A MATLAB v5 .mat with ``key`` an H x W cell array of times (ps), optional ``gate``."""
    from scipy import io as sio

    start = 0 if gate_ps is None else int(gate_ps[0])
    variables = {key: timestamp_cells(events, bin_width_ps, start)}
    if gate_ps is not None:
        variables["gate"] = np.array([float(gate_ps[0]), float(gate_ps[1])])
    sio.savemat(path, variables)
    return Path(path)


def write_cube_npz(path, events, sensor: SensorParams, time_first=False):
    """A .npz with ``counts`` (H x W x T, or T x H x W) and ``bin_width_ps``."""
    cube = histogram(events, events.shape, sensor)
    if time_first:
        cube = np.moveaxis(cube, 2, 0)
    np.savez(path, counts=cube, bin_width_ps=sensor.bin_width_s * 1e12)
    return Path(path)


def write_cube_h5(path, events, sensor: SensorParams):
    """An HDF5 file with dataset ``data/counts`` (H x W x T) and a ``tcspc_resolution`` attr."""
    import h5py

    with h5py.File(path, "w") as f:
        d = f.create_dataset("data/counts", data=histogram(events, events.shape, sensor))
        d.attrs["tcspc_resolution"] = sensor.bin_width_s
    return Path(path)


def write_ptu(path, events, sensor: SensorParams, laser_period_s=None):
    """A PicoQuant PTU T3 image written with ptufile (Y x X x H histogram); the laser
    period defaults to the gate (n_bins bins)."""
    import ptufile

    period = laser_period_s or sensor.n_bins * sensor.bin_width_s
    cube = histogram(events, events.shape, sensor).astype(np.uint16)
    ptufile.imwrite(path, cube, global_resolution=period, tcspc_resolution=sensor.bin_width_s)
    return Path(path)


def write_sparse_mat(path, events, sensor: SensorParams, key="spad"):
    """A MATLAB v5 .mat with ``key`` a sparse (pixels x bins) matrix, pixels in MATLAB
    column-major order, and ``bin_width_ps``."""
    from scipy import io as sio
    from scipy import sparse

    rows, cols = events.shape
    r, c = np.divmod(events.pixel.astype(np.int64), cols)
    matrix = sparse.coo_matrix(
        (np.ones(len(events)), (c * rows + r, events.bin)), shape=(rows * cols, sensor.n_bins)
    ).tocsc()
    sio.savemat(path, {key: matrix, "bin_width_ps": sensor.bin_width_s * 1e12})
    return Path(path)

"""Simulated photon captures written in each format ``spl_al.photon.io`` reads.

A capture is simulated with the measurement model (``simulate_photons``) on a depth
scene, plus background photons on "sky" pixels (no return: they detect background
only), then written as a lab's file would hold it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.photon import PhotonEvents, SensorParams, histogram, simulate_photons


def simulate_capture(depth_m, msppp, sbr, sensor: SensorParams, seed=0, sky=None):
    """Events of a scene at (msppp, sbr); ``sky`` (bool (H, W)) pixels get background only.

    The background per pixel is the same everywhere (mean signal / sbr), so the frame's
    SBR over its valid pixels is ``sbr``.
    """
    rng = np.random.default_rng(seed)
    depth = np.asarray(depth_m, dtype=np.float64)
    sky = np.zeros(depth.shape, bool) if sky is None else sky
    ev = simulate_photons(depth, None, ~sky, msppp, sbr, sensor, rng)
    sky_pix = np.flatnonzero(sky)
    n = rng.poisson(msppp / sbr, size=sky_pix.size)
    pix = np.repeat(sky_pix, n).astype(np.int32)
    bins = rng.integers(0, sensor.n_bins, size=pix.size).astype(np.int32)
    return PhotonEvents(
        np.concatenate([ev.pixel, pix]),
        np.concatenate([ev.bin, bins]),
        np.concatenate([ev.is_signal, np.zeros(pix.size, bool)]),
        ev.shape,
    )


def pixel_bin_counts(events: PhotonEvents) -> np.ndarray:
    """Sorted (pixel, bin) pairs with their counts: a format-independent fingerprint."""
    key = events.pixel.astype(np.int64) * (1 << 32) + events.bin
    values, counts = np.unique(key, return_counts=True)
    return np.stack([values, counts])


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


def write_timestamps_mat(path, events, bin_width_ps: int, gate_ps=None, key="photons"):
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


def write_v73_cells(path, cells, key="photons"):
    """An HDF5 file laid out as MATLAB v7.3 stores a cell array (refs into '#refs#',
    arrays transposed), for the v7.3 reader."""
    import h5py

    rows, cols = cells.shape
    with h5py.File(path, "w") as f:
        refs = f.create_group("#refs#")
        table = np.empty((cols, rows), dtype=h5py.ref_dtype)  # MATLAB order, transposed
        for r in range(rows):
            for c in range(cols):
                a = np.asarray(cells[r, c], dtype=np.float64)
                if a.size:
                    d = refs.create_dataset(f"c{r}_{c}", data=a.T)
                else:
                    d = refs.create_dataset(f"c{r}_{c}", data=np.zeros(2, np.uint64))
                    d.attrs["MATLAB_empty"] = np.uint8(1)
                table[c, r] = d.ref
        cell = f.create_dataset(key, data=table)
        cell.attrs["MATLAB_class"] = np.bytes_("cell")
    return Path(path)

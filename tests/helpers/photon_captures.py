"""Simulated photon captures written in each format ``spl_al.photon.io`` reads.

A capture is simulated with the measurement model (``simulate_photons``) on a depth
scene, plus background photons on "sky" pixels (no return: they detect background
only), then written as a lab's file would hold it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.photon import Condition, PhotonEvents, PhotonScene, SensorParams, simulate_photons
from spl_al.photon.formats.writers import (  # noqa: F401 - the tests import them from here
    timestamp_cells,
    write_cube_h5,
    write_cube_npz,
    write_ptu,
    write_sparse_mat,
    write_timestamps_mat,
)


def simulate_capture(depth_m, msppp, sbr, sensor: SensorParams, seed=0, sky=None):
    """Events of a scene at (msppp, sbr); ``sky`` (bool (H, W)) pixels get background only.

    The background per pixel is the same everywhere (mean signal / sbr), so the frame's
    SBR over its valid pixels is ``sbr``.
    """
    rng = np.random.default_rng(seed)
    depth = np.asarray(depth_m, dtype=np.float64)
    sky = np.zeros(depth.shape, bool) if sky is None else sky
    ev = simulate_photons(PhotonScene(depth, valid=~sky), Condition(msppp, sbr, sensor), rng)
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

"""The photon engine's two records: the sparse photon events of one SPL frame (its
raw measurement R), and the ``Reconstruction`` every reconstruction method recovers
from them (``spl_al.photon.reconstruct`` and ``spl_al.photon.sspi``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from spl_al.photon.sensor import SensorParams


@dataclass(frozen=True)
class PhotonEvents:
    """Every detected photon of one frame, as parallel arrays of length K.

    Attributes:
        pixel: (K,) int32 flat pixel index, row-major into ``shape``.
        bin: (K,) int32 TCSPC time bin in 0..T_max.
        is_signal: (K,) bool, True for laser returns, False for background. Known
            only in simulation; reconstruction never reads it.
        shape: (rows, cols) of the frame.
    """

    pixel: np.ndarray
    bin: np.ndarray
    is_signal: np.ndarray
    shape: tuple[int, int]

    def __len__(self) -> int:
        return int(self.pixel.size)

    def counts(self) -> np.ndarray:
        """(rows, cols) int64 number of photons per pixel."""
        n_pixels = self.shape[0] * self.shape[1]
        return np.bincount(self.pixel, minlength=n_pixels).reshape(self.shape)


def histogram(events: PhotonEvents, shape: tuple[int, int], sensor: SensorParams) -> np.ndarray:
    """Dense photon-count cube N of shape (rows, cols, T).

    Uses the smallest unsigned dtype that holds the largest count (uint8 for most
    frames). Memory is rows * cols * T bytes or more, so prefer the sparse events
    for anything but plots and dense methods.
    """
    rows, cols = shape
    if tuple(events.shape) != (rows, cols):
        raise ValueError(f"shape {shape} does not match the events' frame shape {events.shape}.")
    if events.bin.size and int(events.bin.max()) > sensor.t_max:
        raise ValueError(
            f"events hold time bin {int(events.bin.max())}, beyond the sensor's "
            f"T_max = {sensor.t_max}; pass the sensor the events were recorded with."
        )
    flat = events.pixel.astype(np.int64) * sensor.n_bins + events.bin
    counts = np.bincount(flat, minlength=rows * cols * sensor.n_bins)
    peak = int(counts.max()) if counts.size else 0
    dtype = np.uint8 if peak <= np.iinfo(np.uint8).max else np.uint16
    if peak > np.iinfo(np.uint16).max:
        dtype = np.uint32
    return counts.astype(dtype).reshape(rows, cols, sensor.n_bins)


def events_from_counts(
    pixel: np.ndarray, bin_: np.ndarray, count: np.ndarray, shape
) -> PhotonEvents:
    """Expand (pixel, bin, count) triplets, as stored by a sparse histogram, into events."""
    count = np.asarray(count)
    if np.any(count < 0) or np.any(count != np.rint(count)):
        raise ValueError("photon counts must be non-negative integers.")
    reps = count.astype(np.int64)
    pix = np.repeat(np.asarray(pixel, dtype=np.int32), reps)
    bins = np.repeat(np.asarray(bin_, dtype=np.int32), reps)
    return PhotonEvents(pix, bins, np.zeros(pix.size, dtype=bool), (int(shape[0]), int(shape[1])))


class Reconstruction(NamedTuple):
    """What ``reconstruct`` recovers; every field is a (rows, cols) image.

    depth_m: depth in metres, NaN at voids (pixels without a usable photon).
    reflectivity: estimated signal photons per pixel (the intensity image); 0 at voids.
    background: estimated background photons per pixel over all T bins.
    counts: photons detected per pixel (int64).
    valid: bool, True where depth_m is finite.
    """

    depth_m: np.ndarray
    reflectivity: np.ndarray
    background: np.ndarray
    counts: np.ndarray
    valid: np.ndarray

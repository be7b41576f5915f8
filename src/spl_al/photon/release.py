"""A capture reconstructed into the release layout that spl-al's datasets read.

The layout of the DUIS authors' released frames, which ``spl_al.data.load_folder``
reads: one ``.npz`` per frame with

==================  =================================================================
``depth_ssp``       (H, W) float32 depth in metres from the sensor, 0 = no return
``intensity``       (H, W) float32 estimated signal photons per pixel (SIV's reflectance)
``msppp``           estimated mean signal photons per pixel of the frame
``sbr``             estimated signal-to-background ratio in the gate
``pulse_sigma_s``   instrument response sigma used (given, stated or estimated), s
``bin_width_s``     width of one time bin, s
==================  =================================================================

plus ``pulse_sigma_stderr_s`` (NaN when the sigma was not estimated), ``gate_start_s``
and ``method``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write
from spl_al.photon.calibration import estimate_conditions, estimate_pulse_sigma
from spl_al.photon.capture import Capture
from spl_al.photon.reconstruct import reconstruct
from spl_al.photon.sensor import SPEED_OF_LIGHT_M_PER_S


@dataclass(frozen=True)
class CaptureReconstruction:
    """Depth, intensity and conditions of one capture.

    Attributes:
        depth_m: (H, W) depth in metres from the sensor (gate start added), NaN at voids.
        intensity: (H, W) estimated signal photons per pixel, 0 at voids.
        msppp: estimated signal photons per pixel, mean over all pixels.
        sbr: estimated signal over background photons in the gate.
        pulse_sigma_s: the instrument response sigma used, seconds.
        pulse_sigma_stderr_s: its standard error when estimated from the photons, else NaN.
        bin_width_s: width of one time bin, seconds.
        gate_start_s: arrival time of bin 0, seconds.
        method: the reconstruction method.
    """

    depth_m: np.ndarray
    intensity: np.ndarray
    msppp: float
    sbr: float
    pulse_sigma_s: float
    pulse_sigma_stderr_s: float
    bin_width_s: float
    gate_start_s: float
    method: str

    def release_arrays(self) -> dict[str, np.ndarray]:
        """The arrays of the release layout (module docstring)."""
        return {
            "depth_ssp": np.nan_to_num(self.depth_m, nan=0.0).astype(np.float32),
            "intensity": self.intensity.astype(np.float32),
            "msppp": np.float64(self.msppp),
            "sbr": np.float64(self.sbr),
            "pulse_sigma_s": np.float64(self.pulse_sigma_s),
            "pulse_sigma_stderr_s": np.float64(self.pulse_sigma_stderr_s),
            "bin_width_s": np.float64(self.bin_width_s),
            "gate_start_s": np.float64(self.gate_start_s),
            "method": np.str_(self.method),
        }

    def summary(self) -> str:
        """One line of the figures a user checks first."""
        valid = np.isfinite(self.depth_m)
        depth = (
            f"depth {np.nanmin(self.depth_m):.2f}-{np.nanmax(self.depth_m):.2f} m"
            if valid.any()
            else "no depth"
        )
        sigma = f"pulse sigma {self.pulse_sigma_s * 1e12:.0f} ps"
        if np.isfinite(self.pulse_sigma_stderr_s):
            sigma += f" +- {self.pulse_sigma_stderr_s * 1e12:.0f} (estimated)"
        return (
            f"MSPPP {self.msppp:.2f}, SBR {self.sbr:.3g}, {sigma}, bin "
            f"{self.bin_width_s * 1e12:.4g} ps, {depth}, voids {100 * (~valid).mean():.0f}%"
        )


def drop_isolated(depth_m: np.ndarray, tolerance_m: float, neighbours: int = 2) -> np.ndarray:
    """``depth_m`` (H, W) with NaN where fewer than ``neighbours`` of the 8 neighbours
    hold a depth within ``tolerance_m`` of the pixel's.

    Surfaces span several pixels (a corner pixel of a rectangle has 3 such neighbours);
    a lone return, or a pair, is a cluster of background photons that passed the
    censoring test, which lets through ~5% of background-only windows and which the
    pooled method may spread to a neighbour.
    """
    rows, cols = depth_m.shape
    padded = np.pad(depth_m, 1, constant_values=np.nan)
    near = np.zeros(depth_m.shape, dtype=np.int64)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy or dx:
                other = padded[1 + dy : 1 + dy + rows, 1 + dx : 1 + dx + cols]
                near += np.abs(other - depth_m) <= tolerance_m  # False where either is NaN
    return np.where(near >= neighbours, depth_m, np.nan)


def reconstruct_capture(
    capture: Capture,
    method: str = "pooled",
    *,
    pulse_sigma_s: float | None = None,
    weights=None,
    seed: int = 0,
    censor: bool = True,
) -> CaptureReconstruction:
    """Reconstruct a capture with the sensor its file states and its photons show.

    The pulse sigma is ``pulse_sigma_s``, else the file's, else estimated from the
    photons (``estimate_pulse_sigma``, seeded by ``seed``); MSPPP and SBR come from
    ``estimate_conditions`` on the photons (the frame's time histograms tile by tile,
    which reads them closer than the reconstruction's per-pixel split). Bins much finer than
    the pulse are merged first (``Capture.for_reconstruction``). ``censor`` (ML
    methods) makes pixels that only background photons reached (sky, beyond range)
    voids instead of random depths (``reconstruct``'s ``censor``), and drops lone
    returns (``drop_isolated``, 10 pulse sigmas of depth).
    """
    stderr_s = float("nan")
    sigma_s = pulse_sigma_s if pulse_sigma_s is not None else capture.pulse_sigma_s
    if sigma_s is None:
        estimate = estimate_pulse_sigma(capture.events, capture.n_bins, seed=seed)
        sigma_s = estimate.sigma_bins * capture.bin_width_s
        stderr_s = estimate.stderr_bins * capture.bin_width_s
    binned = capture.for_reconstruction(sigma_s)
    rec = reconstruct(
        binned.events,
        binned.shape,
        binned.sensor(sigma_s),
        method=method,
        censor=censor and method != "sspi",
        weights=weights,
    )
    conditions = estimate_conditions(binned.events, binned.n_bins)
    depth_m = rec.depth_m + capture.gate_depth_m
    if censor and method != "sspi":
        depth_m = drop_isolated(depth_m, 10 * SPEED_OF_LIGHT_M_PER_S * sigma_s / 2)
    return CaptureReconstruction(
        depth_m=depth_m,
        intensity=np.where(np.isfinite(depth_m), rec.reflectivity, 0.0),
        msppp=float(conditions.msppp),
        sbr=float(conditions.sbr),
        pulse_sigma_s=float(sigma_s),
        pulse_sigma_stderr_s=stderr_s,
        bin_width_s=float(capture.bin_width_s),
        gate_start_s=float(capture.gate_start_s),
        method=method,
    )


def save_release(path, result: CaptureReconstruction) -> Path:
    """Write ``result`` to ``path`` (.npz) in the release layout, atomically."""
    arrays = result.release_arrays()

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)

    return atomic_write(path, write)

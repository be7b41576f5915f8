"""One recorded SPL frame: its photons and what the file says of the sensor."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from spl_al.photon.events import PhotonEvents
from spl_al.photon.sensor import SPEED_OF_LIGHT_M_PER_S, SensorParams

TIME_UNITS_S = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "ps": 1e-12, "fs": 1e-15}


def time_unit_s(unit: str) -> float:
    """Seconds in one ``unit`` ("ps", "ns", ...); a ValueError naming the known units."""
    try:
        return TIME_UNITS_S[unit]
    except KeyError:
        raise ValueError(
            f"time unit {unit!r} is not known; expected one of {', '.join(TIME_UNITS_S)}."
        ) from None


@dataclass(frozen=True)
class Capture:
    """The photons of one frame with the timing the file records.

    Time bin t of a photon covers arrival times [gate_start_s + t * bin_width_s,
    gate_start_s + (t + 1) * bin_width_s) after the laser pulse, so its depth is
    d = c (gate_start_s + t * bin_width_s) / 2.

    Attributes:
        events: the photons, bins in 0..n_bins - 1, pixels row-major in ``events.shape``.
        bin_width_s: width of one time bin, seconds.
        n_bins: number of bins in the range gate.
        gate_start_s: arrival time of bin 0 after the laser pulse, seconds.
        pulse_sigma_s: instrument response sigma when the file states it, else None
            (``spl_al.photon.calibration.estimate_pulse_sigma`` estimates it).
        n_frames: frames (or laser pulse trains) summed into the capture, when known.
        format: the reader that produced it ("sparse_mat", "timestamps_mat", "cube", "ptu").
        path: the file.
        notes: what the reader assumed, one sentence each (shown to the user).
    """

    events: PhotonEvents
    bin_width_s: float
    n_bins: int
    gate_start_s: float = 0.0
    pulse_sigma_s: float | None = None
    n_frames: int | None = None
    format: str = ""
    path: str = ""
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        where = f"{self.path}: " if self.path else ""
        if not (np.isfinite(self.bin_width_s) and self.bin_width_s > 0):
            raise ValueError(f"{where}bin width must be > 0 seconds, got {self.bin_width_s!r}.")
        if self.events.bin.size and (
            int(self.events.bin.min()) < 0 or int(self.events.bin.max()) >= self.n_bins
        ):
            raise ValueError(
                f"{where}photon time bins span {int(self.events.bin.min())}.."
                f"{int(self.events.bin.max())}, outside the gate's 0..{self.n_bins - 1}."
            )

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the frame."""
        return self.events.shape

    @property
    def gate_depth_m(self) -> float:
        """Depth of the gate's start, c * gate_start_s / 2: added to every bin's depth."""
        return SPEED_OF_LIGHT_M_PER_S * self.gate_start_s / 2.0

    def sensor(self, pulse_sigma_s: float | None = None) -> SensorParams:
        """The sensor of this capture; ``pulse_sigma_s`` overrides the file's value."""
        sigma = self.pulse_sigma_s if pulse_sigma_s is None else pulse_sigma_s
        if sigma is None:
            raise ValueError(
                f"{self.path or 'capture'}: the file does not state the pulse sigma; "
                "give pulse_sigma_s or estimate it from the photons "
                "(spl_al.photon.calibration.estimate_pulse_sigma)."
            )
        return SensorParams(
            bin_width_s=float(self.bin_width_s),
            pulse_sigma_s=float(sigma),
            n_bins=max(int(self.n_bins), 2),
        )

    def rebinned(self, factor: int) -> Capture:
        """The same photons in bins ``factor`` times wider (bin t -> t // factor)."""
        factor = int(factor)
        if factor < 1:
            raise ValueError(f"rebinning factor must be an integer >= 1, got {factor!r}.")
        if factor == 1:
            return self
        ev = self.events
        return replace(
            self,
            events=PhotonEvents(ev.pixel, ev.bin // factor, ev.is_signal, ev.shape),
            bin_width_s=self.bin_width_s * factor,
            n_bins=-(-self.n_bins // factor),
        )

    def for_reconstruction(self, pulse_sigma_s: float, bins_per_sigma: float = 4.0) -> Capture:
        """This capture in bins of about sigma / ``bins_per_sigma`` when its own are finer.

        Timestamps binned at the electronics' native resolution (a few ps) put hundreds
        of bins in one pulse sigma and leave most bins of the frame's summed histogram
        empty, where the ML reconstruction reads its background level; a quarter sigma
        per bin keeps the depth precision (EM refines below one bin) and gives that
        level back.
        """
        return self.rebinned(max(1, int(pulse_sigma_s / self.bin_width_s / bins_per_sigma)))

    def describe(self) -> str:
        """One line: format, frame shape, photons, bins and gate."""
        rows, cols = self.shape
        gate_end_s = self.gate_start_s + self.n_bins * self.bin_width_s
        return (
            f"{self.format}: {rows}x{cols} pixels, {len(self.events):,} photons, "
            f"{self.n_bins:,} bins of {self.bin_width_s * 1e12:.4g} ps, gate "
            f"{self.gate_start_s * 1e9:.4g}-{gate_end_s * 1e9:.4g} ns"
        )

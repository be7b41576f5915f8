"""Sensor parameters of a time-correlated single-photon counting (TCSPC) LiDAR."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SPEED_OF_LIGHT_M_PER_S = 299_792_458.0


@dataclass(frozen=True)
class SensorParams:
    """Timing of one SPL sensor.

    Attributes:
        bin_width_s: width dt of one TCSPC time bin, seconds.
        pulse_sigma_s: standard deviation of the Gaussian instrument response
            (laser pulse and timing jitter together), seconds.
        n_bins: number of time bins T; valid bins are 0..T_max with T_max = n_bins - 1.

    The default is a tabletop sensor: 1024 bins of 80 ps (12.3 m of range) and a
    pulse of sigma = 2 bins, the setting used across the SPL literature.
    """

    bin_width_s: float = 80e-12
    pulse_sigma_s: float = 160e-12
    n_bins: int = 1024

    def __post_init__(self) -> None:
        if not self.bin_width_s > 0:
            raise ValueError(f"bin_width_s must be > 0 seconds, got {self.bin_width_s!r}.")
        if not self.pulse_sigma_s >= 0:
            raise ValueError(f"pulse_sigma_s must be >= 0 seconds, got {self.pulse_sigma_s!r}.")
        if int(self.n_bins) != self.n_bins or self.n_bins < 2:
            raise ValueError(f"n_bins must be an integer >= 2, got {self.n_bins!r}.")

    @property
    def t_max(self) -> int:
        """Largest valid time bin, T_max = n_bins - 1."""
        return int(self.n_bins) - 1

    @property
    def sigma_bins(self) -> float:
        """Pulse standard deviation in bins, sigma = T_pulse / dt."""
        return self.pulse_sigma_s / self.bin_width_s

    @property
    def bin_depth_m(self) -> float:
        """Depth covered by one time bin, c * dt / 2 (round trip)."""
        return SPEED_OF_LIGHT_M_PER_S * self.bin_width_s / 2.0

    @property
    def max_depth_m(self) -> float:
        """Depth of the last bin, T_max * c * dt / 2: the sensor's reach."""
        return self.t_max * self.bin_depth_m

    @classmethod
    def tabletop(cls) -> SensorParams:
        """1024 bins of 80 ps (12.3 m), sigma = 2 bins: tabletop objects."""
        return cls(bin_width_s=80e-12, pulse_sigma_s=160e-12, n_bins=1024)

    @classmethod
    def paper_real(cls) -> SensorParams:
        """The DUIS paper's scanning sensor: 1 MHz pulses (1 us = 150 m of range),
        80 ps bins and 520 ps of timing jitter taken as the IRF sigma (6.5 bins)."""
        return cls(bin_width_s=80e-12, pulse_sigma_s=520e-12, n_bins=12_500)

    @classmethod
    def ugv45m(cls) -> SensorParams:
        """The ugv45m real captures (Yao et al. 2022): 10,000 bins of 100 ps (1 MHz
        laser, ~150 m), 520 ps jitter as for the paper's sensor (5.2 bins)."""
        return cls(bin_width_s=100e-12, pulse_sigma_s=520e-12, n_bins=10_000)

    @classmethod
    def street(cls) -> SensorParams:
        """Long range for street scenes: 1024 bins of 1 ns (153 m), sigma = 1 bin."""
        return cls(bin_width_s=1e-9, pulse_sigma_s=1e-9, n_bins=1024)

    def depth_to_bin(self, depth_m):
        """Time bin of a depth, t = round(2 d / (c dt)) (numpy rounding: half to even)."""
        return np.rint(np.asarray(depth_m, dtype=np.float64) / self.bin_depth_m).astype(np.int64)

    def bin_to_depth(self, t_bins):
        """Depth of a (possibly fractional) time bin, d = t * c * dt / 2."""
        return np.asarray(t_bins, dtype=np.float64) * self.bin_depth_m

"""Sensor timing stated inside a capture file, under the names spl-al recognises.

A file (``.mat`` variable, ``.npz`` array, HDF5 dataset or attribute) may state:

- the bin width as ``bin_width_s`` (seconds), ``bin_width_ps`` (picoseconds),
  ``tcspc_resolution`` (seconds, PicoQuant's name) or ``bin_width`` (in the
  reader's ``time_unit``);
- the arrival time of bin 0 as ``gate_start_s`` / ``gate_start_ps``;
- the instrument response sigma as ``pulse_sigma_s`` / ``pulse_sigma_ps``;
- for timestamp lists, the range gate as ``gate`` (two numbers, start and stop, in
  ``time_unit``).

A bin width the file states wins over the option (which bins timestamps and gives
the width of files that state none); a pulse sigma given as an option wins over
the file's.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

BIN_WIDTH_NAMES = ("bin_width_s", "bin_width_ps", "tcspc_resolution", "bin_width")


def _number(value) -> float | None:
    a = np.asarray(value)
    if a.size == 1 and a.dtype.kind in "iuf":
        number = float(a.ravel()[0])
        if np.isfinite(number):
            return number
    return None


def _seconds(values: Mapping, base: str, unit_s: float | None = None) -> float | None:
    """``{base}_s`` or ``{base}_ps`` (or plain ``base`` in ``unit_s``) as seconds."""
    for name, factor in ((f"{base}_s", 1.0), (f"{base}_ps", 1e-12), (base, unit_s)):
        if factor is not None and name in values:
            number = _number(values[name])
            if number is not None:
                return number * factor
    return None


def stated_bin_width_s(values: Mapping, unit_s: float) -> float | None:
    """The bin width a file states, seconds; None when it states none."""
    if "tcspc_resolution" in values and _number(values["tcspc_resolution"]) is not None:
        return _number(values["tcspc_resolution"])
    return _seconds(values, "bin_width", unit_s)


def stated_gate_start_s(values: Mapping) -> float | None:
    """Arrival time of bin 0 a file states, seconds; None when it states none."""
    return _seconds(values, "gate_start")


def stated_pulse_sigma_s(values: Mapping) -> float | None:
    """Instrument response sigma a file states, seconds; None when it states none."""
    return _seconds(values, "pulse_sigma")


def stated_gate(values: Mapping, unit_s: float) -> tuple[float, float] | None:
    """Range gate (start, stop) a file states as ``gate`` in ``time_unit``, seconds."""
    if "gate" not in values:
        return None
    a = np.asarray(values["gate"])
    if a.size != 2 or a.dtype.kind not in "iuf":
        return None
    start, stop = (float(x) * unit_s for x in a.ravel())
    return start, stop

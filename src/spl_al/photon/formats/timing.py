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
from pathlib import Path

import numpy as np

from spl_al.photon.capture import Capture
from spl_al.photon.events import PhotonEvents

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


def counts_capture(
    path: Path,
    events: PhotonEvents,
    *,
    n_bins: int,
    values: Mapping,
    format: str,
    given_bin_width_s: float | None,
    unit_s: float,
    layout: tuple[str, float] | None = None,
    notes: tuple[str, ...] = (),
) -> Capture:
    """A Capture of binned counts (sparse matrix or cube) with the timing ``values`` state.

    Bin width: the file's, else ``layout`` (name, bin width) of a known layout (noted), else
    ``given_bin_width_s`` (the option for files that state none), else one error.
    """
    width = stated_bin_width_s(values, unit_s)
    if width is None and layout is not None:
        name, width = layout
        notes = (*notes, f"bin width {width * 1e12:g} ps: the {name} layout (the file states none)")
    width = width if width is not None else given_bin_width_s
    if width is None:
        raise ValueError(
            f"{path}: states no bin width; give it (option bin_width_s, config "
            "bin_width_ps of a dataset's captures or of photon.real_capture_options, "
            "or --bin-width-ps on the command line)."
        )
    return Capture(
        events=events,
        bin_width_s=float(width),
        n_bins=int(n_bins),
        gate_start_s=stated_gate_start_s(values) or 0.0,
        pulse_sigma_s=stated_pulse_sigma_s(values),
        format=format,
        path=str(path),
        notes=notes,
    )

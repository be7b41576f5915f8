"""Per-pixel photon timestamp lists: an H x W cell array of arrival times in a ``.mat``.

Each cell holds the arrival times of one pixel's photons after the laser pulse, in
``time_unit`` (default picoseconds). The times are binned at the native resolution
of the timing electronics (the greatest common divisor of the differences between
the distinct times, when they are whole numbers of ``time_unit``) or at a given
``bin_width_s``. The range gate is the file's ``gate`` variable (start, stop, in
``time_unit``) or the ``gate_s`` option; without either it spans the photons
(from the bin of the earliest to the latest). A time outside a given gate is an
error, not a photon silently dropped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.photon.capture import Capture
from spl_al.photon.events import PhotonEvents
from spl_al.photon.formats.base import CaptureFormat, FileOptions, register
from spl_al.photon.formats.choose import choose_key
from spl_al.photon.formats.matfile import read_mat
from spl_al.photon.formats.timing import stated_gate, stated_pulse_sigma_s

MAX_BINS = 1 << 24  # 16.8 M bins: beyond this the native resolution is surely too fine


def cell_variables(variables: dict) -> list[str]:
    """Names of the 2-D cell arrays among a file's variables."""
    return sorted(
        k
        for k, v in variables.items()
        if isinstance(v, np.ndarray) and v.dtype == object and v.ndim == 2
    )


def timestamp_candidates(variables: dict) -> list[str]:
    """2-D cell arrays that look like arrival times: at least half of their non-empty
    cells numeric (a cell of names or notes is metadata, not photons)."""
    out = []
    for name in cell_variables(variables):
        filled = [np.asarray(c) for c in variables[name].ravel() if np.asarray(c).size]
        numeric = sum(c.dtype.kind in "iuf" for c in filled)
        if filled and 2 * numeric >= len(filled):
            out.append(name)
    return out


def _cell_times(path: Path, key: str, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(times (K,) float64, photons per pixel (H*W,) int64), pixels row-major."""
    flat = cells.ravel(order="C")
    arrays = []
    for p, cell in enumerate(flat):
        a = np.asarray(cell)
        if a.dtype.kind not in "iuf":
            r, c = divmod(p, cells.shape[1])
            kind = "a cell array" if a.dtype == object else f"dtype {a.dtype}"
            raise ValueError(
                f"{path}: {key}{{{r + 1},{c + 1}}} holds {kind}; "
                "expected a numeric array of arrival times."
            )
        arrays.append(a.ravel().astype(np.float64))
    counts = np.fromiter((a.size for a in arrays), dtype=np.int64, count=len(arrays))
    times = np.concatenate(arrays) if arrays else np.zeros(0)
    if not np.isfinite(times).all():
        raise ValueError(f"{path}: {key} holds NaN or infinite arrival times.")
    return times, counts


def _native_resolution(path: Path, times: np.ndarray, unit: str) -> float:
    """Greatest common divisor of the differences of the distinct (whole) times."""
    if not np.array_equal(times, np.rint(times)):
        raise ValueError(
            f"{path}: arrival times are not whole numbers of {unit}, so their native "
            "resolution is unknown; give the bin width (option bin_width_s, or "
            "--bin-width-ps on the command line)."
        )
    distinct = np.unique(times.astype(np.int64))
    if distinct.size < 2:
        return 1.0
    return float(np.gcd.reduce(np.diff(distinct)))


def read_timestamps_mat(
    path: Path,
    variables: dict,
    *,
    key: str | None = None,
    unit: str = "ps",
    unit_s: float = 1e-12,
    bin_width_s: float | None = None,
    gate_s: tuple[float, float] | None = None,
) -> Capture:
    """Capture of the timestamp cell array ``key`` (default: the file's only one)."""
    names = cell_variables(variables)
    key = choose_key(path, names, key, ("2-D cell array", "2-D cell arrays"))
    cells = variables[key]
    times, counts = _cell_times(path, key, cells)
    if times.size == 0:
        raise ValueError(f"{path}: {key} holds no photon (every cell is empty).")

    res = bin_width_s / unit_s if bin_width_s is not None else None
    if res is None:
        res = _native_resolution(path, times, unit)
    if not res > 0:
        raise ValueError(f"{path}: bin width must be > 0, got {res * unit_s!r} s.")
    gate = gate_s if gate_s is not None else stated_gate(variables, unit_s)
    if gate is not None:
        start, stop = gate[0] / unit_s, gate[1] / unit_s
        if not stop > start:
            raise ValueError(f"{path}: gate {gate} s has stop <= start.")
        outside = (times < start) | (times > stop)
        if outside.any():
            raise ValueError(
                f"{path}: {int(outside.sum())} of {times.size} arrival times in {key} lie "
                f"outside the gate {start:g}-{stop:g} {unit} (times span "
                f"{times.min():g}-{times.max():g} {unit}); widen the gate."
            )
    else:
        start, stop = np.floor(times.min() / res) * res, float(times.max())
    n_bins = int(np.floor((stop - start) / res + 1e-9)) + 1
    if n_bins > MAX_BINS:
        raise ValueError(
            f"{path}: a gate of {stop - start:g} {unit} at {res:g} {unit} per bin is "
            f"{n_bins:,} bins (at most {MAX_BINS:,}); give a wider bin width."
        )
    bins = np.floor((times - start) / res + 1e-9).astype(np.int64)
    np.clip(bins, 0, n_bins - 1, out=bins)
    pixel = np.repeat(np.arange(counts.size, dtype=np.int32), counts)
    events = PhotonEvents(
        pixel=pixel,
        bin=bins.astype(np.int32),
        is_signal=np.zeros(pixel.size, dtype=bool),
        shape=(int(cells.shape[0]), int(cells.shape[1])),
    )
    return Capture(
        events=events,
        bin_width_s=res * unit_s,
        n_bins=n_bins,
        gate_start_s=start * unit_s,
        pulse_sigma_s=stated_pulse_sigma_s(variables),
        format="timestamps_mat",
        path=str(path),
    )


def _read(path: Path, options: FileOptions, variables: dict | None) -> Capture:
    return read_timestamps_mat(
        path,
        read_mat(path) if variables is None else variables,
        key=options.key,
        unit=options.time_unit,
        unit_s=options.unit_s,
        bin_width_s=options.bin_width_s,
        gate_s=options.gate_s,
    )


register(
    CaptureFormat(
        name="timestamps_mat",
        suffixes=(".mat",),
        read=_read,
        describe="a .mat with an H x W cell array of arrival times",
        files=".mat",
        detect=timestamp_candidates,
    )
)

"""Import of real photon captures: one entry point, ``load_capture``, for every format.

Formats are registered in ``spl_al.photon.formats``, one module each (the contract is
in ``spl_al.photon.formats.base``); ``load_capture`` dispatches through the registry,
and ``FORMATS``, ``CAPTURE_SUFFIXES``, ``SUPPORTED_FORMATS`` and ``is_capture`` derive
from it. The registered ones (``format="auto"`` tells them apart by the file):

=================  ==================================================================
``sparse_mat``     ``.mat`` holding a sparse pixels x bins count matrix (the ugv45m frames)
``timestamps_mat`` ``.mat`` holding an H x W cell array of arrival times per pixel
``cube``           dense H x W x T / T x H x W counts in ``.mat``, ``.npy``, ``.npz``, HDF5
``ptu``            PicoQuant PTU image (T3 with line/frame markers), read with ``ptufile``
=================  ==================================================================

``.mat`` files of MATLAB v5 and v7.3 (HDF5) are both read. Options (each used by the
formats it applies to): ``key`` (the variable / array / dataset to read),
``time_unit`` ("ps" default: the unit of timestamps and of a plain ``bin_width`` or
``gate`` in the file), ``bin_width_s`` (bin timestamps at this width, or the width
of a file that states none), ``gate_s`` (range gate (start, stop) of timestamps, in
seconds), ``shape`` and ``order`` (sparse matrices), ``time_axis`` (cubes),
``channel`` (PTU). Timing a file states is read under the names listed in
``spl_al.photon.formats.timing``.

``ReadOptions`` holds these options as the config and the command line name them
(``bin_width_ps``, ...): a dataset's ``captures:``, the real-capture pictures and
``python -m spl_al.photon`` all read through its ``load``. A file of any other format
is one line naming ``SUPPORTED_FORMATS``; ``list_captures`` tells a folder's captures
from its other files.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from spl_al.photon import formats
from spl_al.photon.capture import Capture, time_unit_s
from spl_al.photon.events import PhotonEvents
from spl_al.photon.formats import MAT_SUFFIX, FileOptions
from spl_al.photon.formats.cube import names_a_bin_width
from spl_al.photon.formats.matfile import describe_variables, read_mat

# All derived from the registry (``spl_al.photon.formats``): a new format adds itself.
# These are the formats registered at import (every module in ``formats/__init__``);
# ``load_capture``, ``is_capture`` and the messages ask the registry itself.
FORMATS = ("auto", *formats.names())
CAPTURE_SUFFIXES = formats.suffixes()
# The formats in words, for the one line that refuses any other file.
SUPPORTED_FORMATS = formats.base.files_in_words()


def _supported() -> str:
    """What is supported, in words, with the options, for a file no format reads."""
    return (
        f"supported: {formats.base.formats_in_words()} (options: format, key, time_unit, "
        "bin_width_s, gate_s, shape, order, time_axis, channel)"
    )


def load_capture(
    path,
    format: str = "auto",
    *,
    key: str | None = None,
    time_unit: str = "ps",
    bin_width_s: float | None = None,
    gate_s: tuple[float, float] | None = None,
    shape: tuple[int, int] | None = None,
    order: str = "F",
    time_axis: int | None = None,
    channel: int | None = None,
) -> Capture:
    """The photons of one capture file and the sensor timing it states.

    Args:
        path: the capture file.
        format: one of ``FORMATS``; "auto" detects it from the file.
        key, time_unit, bin_width_s, gate_s, shape, order, time_axis, channel: see the
            module docstring; options that do not apply to the format are ignored.

    Returns:
        Capture: events with bins from 0 at the gate start, bin width, number of bins,
        gate start, and the pulse sigma / frame count where the file states them.

    Raises:
        ValueError: one sentence naming the file and what was found, for an unreadable
            or truncated file, an unknown layout, non-numeric cells, times outside the
            gate, a cube whose time axis cannot be told, a PTU without image markers.
    """
    path = Path(path)
    fmt = None if format == "auto" else formats.get(format)
    if not path.is_file():
        raise ValueError(f"{path}: no such capture file.")
    options = FileOptions(
        key=key,
        time_unit=time_unit,
        unit_s=time_unit_s(time_unit),
        bin_width_s=bin_width_s,
        gate_s=gate_s,
        shape=shape,
        order=order,
        time_axis=time_axis,
        channel=channel,
    )
    suffix = path.suffix.lower()
    if fmt is not None and fmt.any_suffix:
        return fmt.read(path, options, None)
    if not formats.of_suffix(suffix):
        raise ValueError(not_a_capture(path))
    if fmt is not None and suffix not in fmt.suffixes:
        raise ValueError(f"{path}: not a capture file this reader knows; {_supported()}.")
    if suffix != MAT_SUFFIX:
        return (fmt or formats.of_suffix(suffix)[0]).read(path, options, None)

    variables = read_mat(path)
    return (fmt or _detect_mat(path, variables, key)).read(path, options, variables)


def _detect_mat(path: Path, variables: dict, key: str | None) -> formats.CaptureFormat:
    """The format of a .mat by what its variables (or the one named ``key``) hold."""
    for fmt in formats.of_suffix(MAT_SUFFIX):
        names = fmt.detect(variables)
        if (key is None and names) or key in names:
            return fmt

    raise ValueError(
        f"{path}: no photon data found among its variables "
        f"({describe_variables(variables)}); {_supported()}."
    )


# How a file is read: the options a dataset's ``captures:``, the real-capture pictures'
# ``photon.real_capture_options`` and the command line's flags all take.
READ_KEYS = ("format", "time_unit", "bin_width_ps", "pulse_sigma_ps", "key", "time_axis", "channel")
# Cubes in these files state their timing only by name (spl_al.photon.formats.timing).
_CUBE_SUFFIXES = tuple(s for s in formats.get("cube").suffixes if s != MAT_SUFFIX)


@dataclass(frozen=True)
class ReadOptions:
    """How capture files are read (``READ_KEYS``; picoseconds where a key says ps).

    One set of options for every place captures are read: a dataset's ``captures:``
    (``spl_al.data.raw_captures.CaptureOptions`` holds them), the real-capture pictures'
    ``photon.real_capture_options`` and ``python -m spl_al.photon``'s flags.
    """

    format: str = "auto"
    time_unit: str = "ps"
    bin_width_ps: float | None = None
    pulse_sigma_ps: float | None = None
    key: str | None = None
    time_axis: int | None = None
    channel: int | None = None

    @classmethod
    def from_dict(cls, values: dict | None, name: str) -> ReadOptions:
        """The options of config key ``name`` (missing keys take defaults)."""
        values = dict(values or {})
        unknown = sorted(set(values) - set(READ_KEYS))
        if unknown:
            raise ValueError(
                f"config key {name!r} has unknown options {unknown}; expected among "
                f"{', '.join(READ_KEYS)}."
            )
        return cls(**values)

    @property
    def pulse_sigma_s(self) -> float | None:
        """The instrument response sigma given, in seconds (None: the file's or estimated)."""
        return None if self.pulse_sigma_ps is None else self.pulse_sigma_ps * 1e-12

    def load_kwargs(self) -> dict:
        """Keyword arguments of ``load_capture`` (the pulse sigma is the caller's)."""
        return {
            "key": self.key,
            "time_unit": self.time_unit,
            "bin_width_s": None if self.bin_width_ps is None else self.bin_width_ps * 1e-12,
            "time_axis": self.time_axis,
            "channel": self.channel,
        }

    def load(self, path) -> Capture:
        """The capture in ``path``, read by ``load_capture`` with these options."""
        return load_capture(path, self.format, **self.load_kwargs())

    def cli_args(self) -> list[str]:
        """These options as ``python -m spl_al.photon`` flags (defaults left out)."""
        args = [] if self.format == "auto" else ["--format", self.format]
        args += [] if self.time_unit == "ps" else ["--time-unit", self.time_unit]
        for name in ("key", "bin_width_ps", "pulse_sigma_ps", "time_axis", "channel"):
            value = getattr(self, name)
            if value is not None:
                args += [f"--{name.replace('_', '-')}", str(value)]
        return args

    def missing_timing(self, path, setting: str) -> str | None:
        """One sentence when ``path`` is a .npy/.npz/HDF5 count cube that states no bin
        width and these options give none, naming ``setting`` (the key to set); else
        None. Read without the counts; a .mat or .ptu is left to the reader."""
        path = Path(path)
        if (
            self.bin_width_ps is not None
            or self.format not in ("auto", "cube")
            or path.suffix.lower() not in _CUBE_SUFFIXES
            or names_a_bin_width(path)
        ):
            return None
        return (
            f"{path}: a count cube that states no bin width, and none is configured; "
            f"set {setting} (the width of its time bins in ps)."
        )


def not_a_capture(path) -> str:
    """The one line for a file of a format no reader knows, naming the supported ones."""
    return (
        f"{path}: not a capture file this reader knows; supported: {formats.base.files_in_words()}."
    )


def is_capture(path) -> bool:
    """Whether ``path`` has the suffix of a format ``load_capture`` reads."""
    return bool(formats.of_suffix(Path(path).suffix.lower()))


def list_captures(root, recursive: bool = True) -> tuple[list[Path], list[Path]]:
    """(captures, other files) in the folder ``root``, each sorted; hidden files and
    folders (a leading dot) are in neither. ``recursive``: search its subfolders too."""
    root = Path(root)
    found = root.rglob("*") if recursive else root.iterdir()
    files = sorted(
        p
        for p in found
        if p.is_file() and not any(part.startswith(".") for part in p.relative_to(root).parts)
    )
    return [p for p in files if is_capture(p)], [p for p in files if not is_capture(p)]


def load_mat(
    path, key: str = "spad", shape: tuple[int, int] = (64, 64), order: str = "F"
) -> PhotonEvents:
    """Photon events of a ``.mat`` holding a sparse (pixels x bins) count matrix.

    The ugv45m layout: ``spad`` is 4096 x 10000, rows are the 64 x 64 pixels in
    MATLAB column-major order. ``load_capture`` reads it with its timing; this
    keeps the events only.
    """
    # Events only: the bin width is not used, so any value stands in for a missing one.
    capture = load_capture(path, "sparse_mat", key=key, shape=shape, order=order, bin_width_s=1.0)
    return capture.events

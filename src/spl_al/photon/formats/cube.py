"""Dense photon-count cubes: H x W x T or T x H x W in ``.mat``, ``.npy``, ``.npz`` or HDF5.

Which axis is time: the ``time_axis`` option (0 for T x H x W, 2 or -1 for
H x W x T), else the rule "time is the axis longer than both others, and it must
be the first or the last". A cube whose longest axis is the middle one, or whose
first and last axes are equally long, cannot be told apart and needs the option.
Counts must be non-negative whole numbers.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from spl_al.photon.capture import Capture
from spl_al.photon.events import events_from_counts
from spl_al.photon.formats.base import CaptureFormat, FileOptions, register
from spl_al.photon.formats.choose import choose_key
from spl_al.photon.formats.timing import BIN_WIDTH_NAMES, counts_capture

CUBE_SUFFIXES = (".npy", ".npz", ".h5", ".hdf5", ".mat")


def cube_names(arrays: dict) -> list[str]:
    """Names of the 3-D numeric arrays among a file's arrays."""
    return sorted(
        k
        for k, v in arrays.items()
        if getattr(v, "ndim", 0) == 3 and np.dtype(v.dtype).kind in "iuf"
    )


def time_axis_of(path: Path, name: str, shape: tuple[int, ...], time_axis: int | None) -> int:
    """The time axis of a cube of ``shape`` (0 or 2) by the option or the module's rule."""
    if time_axis is not None:
        if time_axis not in (0, 2, -1):
            raise ValueError(
                f"time_axis must be 0 (T x H x W) or 2 / -1 (H x W x T), got {time_axis!r}."
            )
        return 0 if time_axis == 0 else 2
    first, middle, last = shape
    if last > max(first, middle):
        return 2
    if first > max(middle, last):
        return 0
    raise ValueError(
        f"{path}: cannot tell which axis of {name} ({'x'.join(map(str, shape))}) is time "
        "(it must be the longest, and the first or the last); give time_axis=0 "
        "for T x H x W or time_axis=2 for H x W x T."
    )


def _read_arrays(path: Path) -> dict[str, object]:
    """Arrays (and scalar values / attributes) of a .npy, .npz or HDF5 file."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            return {"cube": np.load(path, mmap_mode="r", allow_pickle=False)}
        if suffix == ".npz":
            with np.load(path, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise ValueError(
            f"{path}: cannot be read, the file is truncated or not a numpy file ({exc})."
        ) from None
    return _read_hdf5(path)


def _read_hdf5(path: Path) -> dict[str, object]:
    import h5py

    out: dict[str, object] = {}
    try:
        with h5py.File(path, "r") as f:
            out.update({k: np.asarray(v) for k, v in f.attrs.items()})

            def visit(name, item):
                if isinstance(item, h5py.Dataset):
                    out.update({k: np.asarray(v) for k, v in item.attrs.items()})
                    out[name] = item[()] if item.ndim == 3 or item.size == 1 else None

            f.visititems(visit)
    except (OSError, KeyError, RuntimeError) as exc:
        raise ValueError(f"{path}: not a readable HDF5 file ({exc}).") from None
    return {k: v for k, v in out.items() if v is not None}


def names_a_bin_width(path: Path) -> bool:
    """Whether a ``.npy``, ``.npz`` or HDF5 cube file holds a bin width under one of
    ``BIN_WIDTH_NAMES`` (an array, dataset or attribute), read without its counts: a
    ``.npy`` holds one array and never does. An unreadable file counts as naming one
    (the reader then says what is wrong with it)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npy":
        return False
    try:
        if suffix == ".npz":
            with zipfile.ZipFile(path) as z:
                names = {Path(n).stem for n in z.namelist()}
        else:
            import h5py

            names = set()
            with h5py.File(path, "r") as f:
                names.update(f.attrs)

                def visit(name, item):
                    names.add(name.rsplit("/", 1)[-1])
                    names.update(item.attrs)

                f.visititems(visit)
    except (OSError, KeyError, RuntimeError, zipfile.BadZipFile):
        return True
    return any(name in names for name in BIN_WIDTH_NAMES)


def read_cube(
    path: Path,
    arrays: dict,
    *,
    key: str | None = None,
    time_axis: int | None = None,
    bin_width_s: float | None = None,
    unit_s: float = 1e-12,
) -> Capture:
    """Capture of the cube ``key`` (default: the only 3-D numeric array) of ``arrays``."""
    names = cube_names(arrays)
    key = choose_key(path, names, key, ("3-D numeric array", "3-D numeric arrays"))
    cube = np.asarray(arrays[key])
    axis = time_axis_of(path, key, cube.shape, time_axis)
    if axis == 0:
        cube = np.moveaxis(cube, 0, 2)
    rows, cols, n_bins = cube.shape
    r, c, t = np.nonzero(cube)
    counts = cube[r, c, t]
    try:
        events = events_from_counts(r * cols + c, t, counts, (rows, cols))
    except ValueError as exc:
        raise ValueError(f"{path}: {key}: {exc}") from None
    return counts_capture(
        path,
        events,
        n_bins=n_bins,
        values=arrays,
        format="cube",
        given_bin_width_s=bin_width_s,
        unit_s=unit_s,
        notes=(f"time axis {axis} of {key}",),
    )


def _read(path: Path, options: FileOptions, variables: dict | None) -> Capture:
    """A .mat's cube from its variables (read once by ``load_capture``), else the file's."""
    arrays = _read_arrays(path) if variables is None else variables
    return read_cube(
        path,
        arrays,
        key=options.key,
        time_axis=options.time_axis,
        bin_width_s=options.bin_width_s,
        unit_s=options.unit_s,
    )


register(
    CaptureFormat(
        name="cube",
        suffixes=CUBE_SUFFIXES,
        read=_read,
        describe="a 3-D count cube in .mat/.npy/.npz/.h5",
        files="HDF5 (.h5, .hdf5) and .npy/.npz count cubes",
        detect=cube_names,
    )
)

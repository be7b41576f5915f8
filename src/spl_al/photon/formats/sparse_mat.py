"""A sparse (pixels x bins) photon-count matrix in a ``.mat`` (the ``ugv45m`` layout).

The layout of Yao et al. 2022: ``spad`` is a 4096 x 10000 sparse matrix whose rows
are the 64 x 64 pixels in MATLAB column-major order (``order="F"``: pixel p is at
row p % 64, column p // 64) and whose columns are time bins. Files of that exact
layout that state no bin width get the authors' 100 ps (1 MHz laser, 10,000 bins =
1 us), and the capture says so in its notes.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from spl_al.photon.capture import Capture
from spl_al.photon.events import events_from_counts
from spl_al.photon.formats.base import CaptureFormat, FileOptions, register
from spl_al.photon.formats.choose import choose_key
from spl_al.photon.formats.matfile import read_mat
from spl_al.photon.formats.timing import counts_capture

UGV45M_BIN_WIDTH_S = 100e-12


def sparse_variables(variables: dict) -> list[str]:
    """Names of the sparse matrices among a file's variables."""
    from scipy import sparse

    return sorted(k for k, v in variables.items() if sparse.issparse(v))


def read_sparse_mat(
    path: Path,
    variables: dict,
    *,
    key: str | None = None,
    shape: tuple[int, int] | None = None,
    order: str = "F",
    bin_width_s: float | None = None,
    unit_s: float = 1e-12,
) -> Capture:
    """Capture of the sparse matrix ``key`` (default: the file's only sparse matrix).

    ``shape`` is the frame's (rows, cols); by default a square frame of the matrix's
    row count. ``order`` says how a row index p maps to a pixel: "F" (MATLAB,
    column-major) or "C" (row-major). The bin width is the file's, else the ugv45m
    layout's, else ``bin_width_s`` (the width of files that state none).
    """
    from scipy import sparse

    names = sparse_variables(variables)
    key = choose_key(path, names, key, ("sparse matrix", "sparse matrices"))
    matrix = sparse.coo_matrix(variables[key])
    n_pixels, n_bins = matrix.shape
    if shape is None:
        side = math.isqrt(n_pixels)
        if side * side != n_pixels:
            raise ValueError(
                f"{path}: {key!r} has {n_pixels} rows (pixels), not a square frame; "
                "give the frame's shape (option shape=(rows, cols))."
            )
        shape = (side, side)
    rows, cols = (int(s) for s in shape)
    if rows * cols != n_pixels:
        raise ValueError(
            f"{path}: {key!r} has {n_pixels} rows, expected {rows * cols} pixels for shape {shape}."
        )
    p = matrix.row.astype(np.int64)
    if order == "F":
        r, c = p % rows, p // rows
    elif order == "C":
        r, c = p // cols, p % cols
    else:
        raise ValueError(f"order must be 'F' or 'C', got {order!r}.")
    try:
        events = events_from_counts(r * cols + c, matrix.col, matrix.data, (rows, cols))
    except ValueError as exc:
        raise ValueError(f"{path}: variable {key!r}: {exc}") from None

    ugv45m = key == "spad" and n_bins == 10_000
    return counts_capture(
        path,
        events,
        n_bins=n_bins,
        values=variables,
        format="sparse_mat",
        given_bin_width_s=bin_width_s,
        unit_s=unit_s,
        layout=("ugv45m", UGV45M_BIN_WIDTH_S) if ugv45m else None,
    )


def _read(path: Path, options: FileOptions, variables: dict | None) -> Capture:
    return read_sparse_mat(
        path,
        read_mat(path) if variables is None else variables,
        key=options.key,
        shape=options.shape,
        order=options.order,
        bin_width_s=options.bin_width_s,
        unit_s=options.unit_s,
    )


register(
    CaptureFormat(
        name="sparse_mat",
        suffixes=(".mat",),
        read=_read,
        describe="a .mat with a sparse pixels x bins matrix",
        files=".mat",
        detect=sparse_variables,
    )
)

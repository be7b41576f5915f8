"""Import of real photon captures."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spl_al.photon.events import PhotonEvents, events_from_counts


def load_mat(
    path, key: str = "spad", shape: tuple[int, int] = (64, 64), order: str = "F"
) -> PhotonEvents:
    """Photon events of a MATLAB capture holding a sparse (pixels x bins) count matrix.

    The layout of Yao et al. 2022 (the ``ugv45m`` captures): ``spad`` is 4096 x 10000,
    rows are the 64 x 64 pixels in MATLAB column-major order (``order="F"``: pixel
    p is at row p % 64, column p // 64), columns are time bins.

    Returns events with flat pixel indices in this package's row-major convention.
    """
    from scipy import io as sio  # scipy is heavy to import; only this reader needs it
    from scipy import sparse

    path = Path(path)
    try:
        data = sio.loadmat(path)
    except Exception as exc:  # scipy raises several types for broken files
        raise ValueError(f"{path}: not a readable MATLAB .mat file ({exc}).") from None
    if key not in data:
        found = sorted(k for k in data if not k.startswith("__"))
        raise ValueError(f"{path}: no variable {key!r}; found {found}.")
    matrix = sparse.coo_matrix(data[key])
    rows, cols = shape
    if matrix.shape[0] != rows * cols:
        raise ValueError(
            f"{path}: {key!r} has {matrix.shape[0]} rows, expected {rows * cols} pixels "
            f"for shape {shape}."
        )
    p = matrix.row.astype(np.int64)
    if order == "F":
        r, c = p % rows, p // rows
    elif order == "C":
        r, c = p // cols, p % cols
    else:
        raise ValueError(f"order must be 'F' or 'C', got {order!r}.")
    return events_from_counts(r * cols + c, matrix.col, matrix.data, (rows, cols))

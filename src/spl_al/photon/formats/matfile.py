"""The variables of a MATLAB ``.mat`` file, v5 (scipy) or v7.3 (HDF5, h5py), alike.

Both give numpy arrays in MATLAB's axis order (v7.3 stores them transposed),
cell arrays as object arrays of numpy arrays and sparse matrices as
``scipy.sparse`` matrices, so a reader never asks which version wrote the file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def read_mat(path: Path) -> dict[str, object]:
    """{name: value} of every variable of a ``.mat`` file; a ValueError for anything else."""
    import h5py

    if h5py.is_hdf5(path):
        return _read_v73(path)
    from scipy import io as sio  # heavy to import; only .mat readers need it

    try:
        data = sio.loadmat(path)
    except Exception as exc:  # scipy raises several types for broken files
        raise ValueError(f"{path}: not a readable MATLAB .mat file ({exc}).") from None
    return {k: v for k, v in data.items() if not k.startswith("__")}


def _read_v73(path: Path) -> dict[str, object]:
    import h5py

    try:
        with h5py.File(path, "r") as f:
            return {
                name: _h5_value(f, item)
                for name, item in f.items()
                if not name.startswith("#")  # '#refs#' holds the cells' contents
            }
    except (OSError, KeyError, RuntimeError) as exc:
        raise ValueError(f"{path}: not a readable MATLAB v7.3 (HDF5) file ({exc}).") from None


def _h5_value(f, item):
    import h5py

    if isinstance(item, h5py.Group):
        if "MATLAB_sparse" in item.attrs:
            from scipy import sparse

            n_rows = int(item.attrs["MATLAB_sparse"])
            jc = item["jc"][()].astype(np.int64)
            data = item["data"][()] if "data" in item else np.zeros(0)
            ir = item["ir"][()].astype(np.int64) if "ir" in item else np.zeros(0, np.int64)
            return sparse.csc_matrix((data, ir, jc), shape=(n_rows, jc.size - 1))
        return {k: _h5_value(f, v) for k, v in item.items()}
    if item.attrs.get("MATLAB_empty", 0):
        return np.zeros((0, 0))
    value = item[()]
    if item.dtype == h5py.ref_dtype:
        cells = np.empty(value.shape, dtype=object)
        for index in np.ndindex(value.shape):
            cells[index] = _h5_value(f, f[value[index]])
        return cells.T
    return np.asarray(value).T


def describe_variables(variables: dict[str, object]) -> str:
    """``name (shape dtype), ...`` for an error message."""
    from scipy import sparse

    parts = []
    for name, value in sorted(variables.items()):
        if sparse.issparse(value):
            parts.append(f"{name} (sparse {value.shape[0]}x{value.shape[1]})")
        elif isinstance(value, np.ndarray):
            kind = "cell" if value.dtype == object else str(value.dtype)
            parts.append(f"{name} ({'x'.join(map(str, value.shape))} {kind})")
        else:
            parts.append(f"{name} ({type(value).__name__})")
    return ", ".join(parts) or "no variables"

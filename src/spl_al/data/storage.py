"""On-disk encoding of depth images and atomic ``.npz`` writes.

Depth is stored as uint16 codes of a fixed step (``depth_step_m``): code =
round(depth / step), with 65535 reserved for voids. The step is the smallest of
0.5 mm, 1 mm, 2 mm, 2.5 mm, 5 mm, ... that reaches the largest depth, so the
rounding error is at most step / 2 (1.25 mm up to 163 m), far below the depth
resolution of any SPL sensor here (one 80 ps bin is 12 mm).
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write

VOID_CODE = np.iinfo(np.uint16).max
_MAX_CODE = VOID_CODE - 1
_NICE_STEPS_M = tuple(m * 10.0**e for e in range(-4, 2) for m in (1.0, 2.0, 2.5, 5.0))


def choose_depth_step(max_depth_m: float) -> float:
    """Smallest nice step (>= 0.5 mm) whose 65534 codes reach ``max_depth_m``."""
    if not np.isfinite(max_depth_m) or max_depth_m < 0:
        raise ValueError(f"max_depth_m must be a finite depth >= 0, got {max_depth_m!r}.")
    for step in _NICE_STEPS_M:
        if step >= 5e-4 and step * _MAX_CODE >= max_depth_m:
            return step
    raise ValueError(f"depth {max_depth_m:.4g} m is too large to encode in uint16 codes.")


def encode_depth(depth_m: np.ndarray, step_m: float) -> np.ndarray:
    """uint16 codes of a depth array (NaN -> void code)."""
    depth = np.asarray(depth_m, dtype=np.float64)
    finite = np.isfinite(depth)
    code = np.full(depth.shape, VOID_CODE, dtype=np.uint16)
    code[finite] = np.clip(np.rint(depth[finite] / step_m), 0, _MAX_CODE).astype(np.uint16)
    return code


def decode_depth(code: np.ndarray, step_m: float) -> np.ndarray:
    """float32 depth of uint16 codes, NaN at the void code."""
    code = np.asarray(code)
    depth = code.astype(np.float32)  # one pass and one array: jobs decode on every load
    depth *= np.float32(step_m)
    depth[code == VOID_CODE] = np.nan
    return depth


def atomic_savez(path, arrays: dict[str, np.ndarray], meta: dict, compress: bool = True) -> Path:
    """Write ``arrays`` plus ``meta`` (as JSON under the key ``meta_json``) to ``path``.

    The file is a standard ``.npz`` (``np.load`` reads it), deflated at zlib level 1:
    nearly the size of the default level (depth codes and masks compress well) at a
    third of the time. Written through ``spl_al.atomic.atomic_write`` (temporary file
    + rename), so a reader never sees a half-written file.
    """
    payload = dict(arrays)
    payload["meta_json"] = np.frombuffer(json.dumps(meta, allow_nan=False).encode(), dtype=np.uint8)
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED

    def write(tmp: Path) -> None:
        with zipfile.ZipFile(tmp, "w", compression=method, compresslevel=1) as zf:
            for key, value in payload.items():
                with zf.open(f"{key}.npy", "w", force_zip64=True) as fh:
                    np.lib.format.write_array(fh, np.asanyarray(value), allow_pickle=False)

    return atomic_write(path, write)


def read_npz(path, kind: str, skip=(), only=None) -> tuple[dict[str, np.ndarray], dict]:
    """Arrays and JSON meta of a file written by ``atomic_savez``; ``kind`` names the
    expected ``meta["format"]`` for the error message. Arrays named in ``skip``, and
    with ``only`` given those it does not name, are neither read nor decompressed."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file (expected an {kind} .npz).")
    try:
        with np.load(path, allow_pickle=False) as z:
            wanted = [k for k in z.files if k not in skip]
            if only is not None:
                wanted = [k for k in wanted if k in set(only) | {"meta_json"}]
            arrays = {k: z[k] for k in wanted}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise ValueError(f"{path}: cannot be read as an {kind} .npz file ({exc}).") from None
    if "meta_json" not in arrays:
        raise ValueError(f"{path}: not an {kind} file (no 'meta_json' entry).")
    meta = json.loads(arrays.pop("meta_json").tobytes().decode())
    if meta.get("format") != kind:
        raise ValueError(f"{path}: holds format {meta.get('format')!r}, expected {kind!r}.")
    return arrays, meta

"""Finding, reading and checking the published SSPI weights.

The trained weights come with the authors' code, not with spl-al (their repository
has no license file, so spl-al never copies them): download ``ssunet1.pth`` (the
denoiser) and ``ssunet2.pth`` (the depth estimator) from
https://github.com/y2w-oc/Dynamic-SSP-3D-Imaging, folder ``Test/preTrain/``, into
one folder, and point spl-al at that folder with ``weights=``, the config key
``photon.sspi_weights`` or the environment variable ``SPL_AL_SSPI_WEIGHTS``.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path

import torch

from spl_al.config import SSPI_WEIGHTS_ENV
from spl_al.photon.sspi.network import SSPI, expected_shapes

FILES = ("ssunet1.pth", "ssunet2.pth")  # denoiser, depth estimator
SOURCE = (
    "download ssunet1.pth and ssunet2.pth from the authors' repository "
    "https://github.com/y2w-oc/Dynamic-SSP-3D-Imaging (folder Test/preTrain/) into one "
    f"folder and pass it as weights=FOLDER, config key photon.sspi_weights or ${SSPI_WEIGHTS_ENV}"
)


def weights_folder(weights=None) -> Path:
    """The folder holding ``ssunet1.pth`` and ``ssunet2.pth``.

    ``weights`` (a folder) wins; otherwise ``$SPL_AL_SSPI_WEIGHTS``. Raises one
    ValueError saying where to get the weights when neither is set or a file is missing.
    """
    chosen = weights if weights not in (None, "") else os.environ.get(SSPI_WEIGHTS_ENV) or None
    if chosen is None:
        raise ValueError(f"SSPI needs its trained weights, and none were given: {SOURCE}.")
    folder = Path(chosen).expanduser()
    missing = [name for name in FILES if not (folder / name).is_file()]
    if missing:
        raise ValueError(f"SSPI weights folder {folder} lacks {', '.join(missing)}: {SOURCE}.")
    return folder


def load_state(path) -> dict[str, torch.Tensor]:
    """The validated ``state_dict`` of one SSPI checkpoint (tensors on CPU).

    Accepts a checkpoint dict with a ``state_dict`` entry (as published) or a bare
    state dict. Raises one ValueError naming the file and the first problem: not a
    torch checkpoint, a missing or unexpected key, or a wrong shape.
    """
    path = Path(path)
    try:
        checkpoint = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for a foreign file
        raise ValueError(f"{path}: not a torch checkpoint ({type(exc).__name__}: {exc}).") from None
    state = checkpoint.get("state_dict", checkpoint) if isinstance(checkpoint, dict) else None
    if not isinstance(state, dict):
        raise ValueError(f"{path}: not an SSPI checkpoint (expected a dict with 'state_dict').")
    expected = expected_shapes()
    for key, shape in expected.items():
        if key not in state:
            raise ValueError(f"{path}: not an SSPI checkpoint, missing key {key!r}.")
        value = state[key]
        if not isinstance(value, torch.Tensor) or tuple(value.shape) != shape:
            got = tuple(value.shape) if isinstance(value, torch.Tensor) else type(value).__name__
            raise ValueError(f"{path}: key {key!r} has shape {got}, expected {shape}.")
    extra = sorted(set(state) - set(expected))
    if extra:
        raise ValueError(f"{path}: not an SSPI checkpoint, unexpected key {extra[0]!r}.")
    return {key: state[key] for key in expected}


@lru_cache(maxsize=4)
def _load(folder: str, stamp: tuple, device: str) -> SSPI:
    first, second = (load_state(Path(folder) / name) for name in FILES)
    return SSPI(first, second, device)


def load_sspi(weights=None, device=None) -> SSPI:
    """The SSPI network with the weights of ``weights_folder(weights)``, cached per
    folder, file times and device (so a run over many frames reads them once).

    ``device`` defaults to CUDA when available, else CPU.
    """
    folder = weights_folder(weights).resolve()
    stamp = tuple((folder / name).stat().st_mtime_ns for name in FILES)
    if device is None:
        device = "cuda" if torch.cuda.is_available() else "cpu"
    return _load(str(folder), stamp, str(device))

"""SSPI reconstruction (Yao et al. 2022) in plain PyTorch, with the published weights.

- ``sparse``: sparse tensors and submanifold / strided / inverse sparse convs as
  gather / matmul / scatter over kernel offsets.
- ``network``: the two sparse U-Nets, the fixed dilation and the arg-max readout.
- ``weights``: where the weights come from, loading and validation.

``reconstruct_sspi`` is what ``spl_al.photon.reconstruct(..., method="sspi")`` calls.
"""

from __future__ import annotations

import warnings

import numpy as np

from spl_al.photon.events import PhotonEvents, Reconstruction
from spl_al.photon.sensor import SensorParams

TRAINED_BIN_WIDTH_S = (80e-12, 100e-12)  # simulations at 80 ps, real captures at 100 ps
TRAINED_FRAME = (64, 64)
_WARNED: set[str] = set()


def check_conditions(sensor: SensorParams, shape) -> list[str]:
    """Reasons the frame lies outside what the weights were trained on; warns once each.

    The network is fully convolutional and runs on any bin width and frame size,
    but its kernels count in bins and pixels: at other bin widths the pulse and a
    surface's slope span other numbers of bins than in training, and its accuracy
    there is unmeasured. Depth is read out in whole bins either way.
    """
    reasons = {}  # kind -> message; each kind warns once per process
    lo, hi = TRAINED_BIN_WIDTH_S
    if not lo * (1 - 1e-6) <= sensor.bin_width_s <= hi * (1 + 1e-6):
        reasons[f"bin width {sensor.bin_width_s}"] = (
            f"bin width {sensor.bin_width_s * 1e12:g} ps is outside the 80-100 ps "
            "the SSPI weights were trained on"
        )
    if tuple(int(s) for s in shape) != TRAINED_FRAME:
        reasons["frame"] = (
            f"frames such as {tuple(shape)} differ from the 64x64 frames the SSPI weights "
            "were trained on"
        )
    for kind, reason in reasons.items():
        if kind not in _WARNED:
            _WARNED.add(kind)
            warnings.warn(
                f"{reason}; SSPI runs unchanged but its accuracy there is unmeasured.", stacklevel=3
            )
    return list(reasons.values())


def reconstruct_sspi(
    events: PhotonEvents, shape, sensor: SensorParams, *, weights=None, device=None, window_bins=3
):
    """SSPI depth, with reflectivity and background counted around it.

    Depth: d = t_hat * c dt / 2 with t_hat the network's arg-max bin (the original
    adds a constant 0.012 m, one 80 ps bin of its 1-based MATLAB bin numbering;
    here bins are numbered as in ``SensorParams``: bin t is depth t c dt / 2).
    Photons within +-``window_bins`` of t_hat (the dilation's reach in time) count
    as signal n_in; the rest are background spread over the T bins:
    background = (counts - n_in) T / (T - w), reflectivity = max(n_in - background w / T, 0),
    w = 2 window_bins + 1.

    Returns:
        ``spl_al.photon.Reconstruction``, each field (rows, cols).
    """
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.photon.sspi.weights import load_sspi

    rows, cols = (int(shape[0]), int(shape[1]))
    net = load_sspi(weights, device)
    check_conditions(sensor, (rows, cols))
    n_bins = sensor.n_bins
    key = events.pixel.astype(np.int64) * n_bins + events.bin
    cell, count = np.unique(key, return_counts=True)
    pixel, t = cell // n_bins, cell % n_bins
    coords = torch.from_numpy(np.stack((t, pixel // cols, pixel % cols), axis=1))
    out = net(coords, torch.from_numpy(count), (n_bins, rows, cols))
    depth_bin = out["depth_bin"].cpu().numpy().ravel()

    counts = np.bincount(events.pixel, minlength=rows * cols)
    has = depth_bin >= 0
    near = has[events.pixel] & (np.abs(events.bin - depth_bin[events.pixel]) <= window_bins)
    n_in = np.bincount(events.pixel[near], minlength=rows * cols)
    window = 2 * window_bins + 1
    background = (counts - n_in) * n_bins / max(n_bins - window, 1)
    reflectivity = np.where(has, np.clip(n_in - background * window / n_bins, 0.0, None), 0.0)
    depth = np.where(has, sensor.bin_to_depth(depth_bin), np.nan)
    return Reconstruction(
        depth.reshape(rows, cols),
        reflectivity.reshape(rows, cols),
        background.reshape(rows, cols),
        counts.reshape(rows, cols),
        has.reshape(rows, cols),
    )

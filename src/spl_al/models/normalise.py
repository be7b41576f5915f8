"""Per-image depth normalisation that survives voids and varying distance.

An SPL depth image has voids (pixels without a usable photon, NaN) and its range
depends on where the sensor stood, so a fixed global scaling would make the same
object look different at 1 m and at 3 m. Each image is therefore standardised
robustly over its own valid pixels:

    z(p) = clip( (depth(p) - median_P depth) / s, -CLIP, CLIP ),   p in P (valid)
    s    = max( 1.4826 * median_P |depth - median_P depth|,  REL_FLOOR * |median|,  ABS_FLOOR_M )

The median removes the distance offset; 1.4826 * MAD is a standard deviation that
background-photon outliers (random depths at low photon counts) cannot inflate;
the floors keep a flat wall from being blown up into noise; the clip bounds the
outliers that remain. Voids get z = 0 and a second channel carries validity
(1 valid, 0 void), so the network can tell "at the median" from "no data".
An image with no valid pixel becomes all zeros. (torch's median of an even count
is the lower of the two middle values.)
"""

from __future__ import annotations

import numpy as np
import torch

CLIP = 4.0
REL_FLOOR = 0.01
ABS_FLOOR_M = 1e-3
MAD_TO_STD = 1.4826


def _as_tensor(a, dtype) -> torch.Tensor:
    if isinstance(a, torch.Tensor):
        return a.to(dtype)
    return torch.from_numpy(np.ascontiguousarray(a)).to(dtype)


def _nanmedian(flat: torch.Tensor) -> torch.Tensor:
    """(B, N) -> (B,): the lower median of each row's non-NaN values (NaN for none).

    ``torch.nanmedian`` has no ONNX counterpart, so while ``torch.onnx.export`` traces
    the same median is taken by sorting (NaN as +inf, last) and picking entry
    (n - 1) // 2 of the n non-NaN values: the same selection, the same values.
    """
    if not torch.onnx.is_in_onnx_export():
        return flat.nanmedian(dim=1).values
    missing = torch.isnan(flat)
    ordered = torch.sort(torch.where(missing, torch.inf, flat), dim=1).values
    n = (~missing).sum(dim=1, keepdim=True)
    middle = torch.div(n - 1, 2, rounding_mode="floor").clamp_min(0)
    median = ordered.gather(1, middle)[:, 0]
    return torch.where(n[:, 0] > 0, median, torch.nan)


def to_input(depth_m, valid=None) -> torch.Tensor:
    """Network input from depth images: normalised depth and a validity channel.

    Args:
        depth_m: (H, W) or (B, H, W) depth in metres, numpy or torch; NaN/inf at voids.
        valid: optional bool mask of the same shape; a pixel counts as valid only if
            it is marked valid *and* its depth is finite. None: finite pixels.

    Returns:
        float32 tensor (B, 2, H, W) on the device of ``depth_m`` (CPU for numpy):
        channel 0 the robustly standardised depth (module docstring), 0 at voids;
        channel 1 the validity (1.0 / 0.0).
    """
    depth = _as_tensor(depth_m, torch.float32)
    if depth.ndim == 2:
        depth = depth[None]
    if depth.ndim != 3:
        raise ValueError(f"depth_m must have shape (H, W) or (B, H, W), got {tuple(depth.shape)}.")
    ok = torch.isfinite(depth)
    if valid is not None:
        v = _as_tensor(valid, torch.bool).to(depth.device)
        if v.ndim == 2:
            v = v[None]
        if v.shape != depth.shape:
            raise ValueError(
                f"valid must have the shape of depth_m {tuple(depth.shape)}, got {tuple(v.shape)}."
            )
        ok = ok & v
    b = depth.shape[0]
    flat = torch.where(ok, depth, torch.nan).reshape(b, -1)
    if flat.shape[1] == 0:
        return torch.zeros((b, 2, *depth.shape[1:]), dtype=torch.float32, device=depth.device)
    centre = _nanmedian(flat)  # NaN where an image has no valid pixel
    mad = _nanmedian((flat - centre[:, None]).abs())
    scale = torch.maximum(MAD_TO_STD * mad, REL_FLOOR * centre.abs()).clamp_min(ABS_FLOOR_M)
    centre = torch.nan_to_num(centre, nan=0.0)
    scale = torch.nan_to_num(scale, nan=1.0)
    z = ((flat - centre[:, None]) / scale[:, None]).clamp(-CLIP, CLIP)
    z = torch.nan_to_num(z, nan=0.0).reshape(depth.shape)
    return torch.stack([z, ok.to(torch.float32)], dim=1)


def to_range_input(depth_m, valid=None) -> torch.Tensor:
    """Network input in metres for point networks: (B, 2, H, W) = (range, validity).

    Same arguments and validity rule as ``to_input``, but channel 0 keeps the metric
    range (0 at voids) instead of standardising it: a point network needs metres to
    place each return at range * ray direction.
    """
    x = to_input(depth_m, valid)  # validates shapes and builds the validity channel
    depth = _as_tensor(depth_m, torch.float32).to(x.device).reshape(x[:, 0].shape)
    ok = x[:, 1] > 0
    return torch.stack([torch.where(ok, depth, 0.0), x[:, 1]], dim=1)

"""Batched inference: class probabilities and penultimate features."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from spl_al.models import model_input
from spl_al.training.compute import LOCAL, Compute
from spl_al.training.precision import autocast

FEATURE_MODES = ("image", "pixel", "none")


def iter_forward(
    model: nn.Module,
    depth_m,
    valid,
    *,
    compute: Compute | None = None,
    batch_size: int = 256,
) -> Iterator[tuple[int, torch.Tensor, torch.Tensor, torch.Tensor]]:
    """Run ``model`` in eval mode over images in batches, without gradients.

    Args:
        depth_m, valid: (n, H, W) arrays (numpy, memory-mapped or torch).
        compute: the device and the precision of the passes (``Compute``; resolved
            for the model unless it is already; None: ``LOCAL``, fp32); the outputs
            are float32 whatever the precision.

    Yields:
        (start, probs, features, valid) per batch, on the device: probs (b, C) or
        (b, C, H, W) float32 softmax; features (b, d) or (b, d, H, W); valid (b, H, W)
        bool, the pixels that are valid and finite.
    """
    if batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}.")
    compute = (compute or LOCAL).resolved(model)
    dev, precision = compute.torch_device, compute.precision
    model.to(dev).eval()
    # Mixed precision runs convolutions channels-last (oneDNN's fast bf16 layout; 1.6x
    # here); fp32 keeps the layout it always had, so its numbers stay as they were.
    convolutional = isinstance(model, nn.Module) and any(
        isinstance(m, nn.Conv2d) for m in model.modules()
    )
    layout = (
        torch.channels_last if precision != "fp32" and convolutional else torch.contiguous_format
    )
    n = len(depth_m)
    if convolutional:
        model.to(memory_format=layout)
    try:
        with torch.inference_mode():
            for start in range(0, n, batch_size):
                stop = min(start + batch_size, n)
                x = model_input(
                    model, np.asarray(depth_m[start:stop]), np.asarray(valid[start:stop])
                )
                x = x.to(dev).contiguous(memory_format=layout)
                with autocast(precision, dev):
                    logits, features = model(x)
                yield start, torch.softmax(logits.float(), dim=1), features.float(), x[:, 1] > 0
    finally:
        if convolutional:
            model.to(memory_format=torch.contiguous_format)


def pool_pixels(values: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean of per-pixel values (b, k, H, W) over the pixels in ``mask`` (b, H, W): (b, k).

    An image without any masked pixel is averaged over all its pixels instead.
    """
    m = mask.to(values.dtype)
    empty = m.sum(dim=(1, 2)) == 0
    m = torch.where(empty.view(-1, 1, 1), torch.ones_like(m), m)
    return torch.einsum("bkhw,bhw->bk", values, m) / m.sum(dim=(1, 2)).unsqueeze(1)


@dataclass
class Predictions:
    """Model outputs for n images.

    probs: (n, C) or, for segmentation, (n, C, H, W) float32 class probabilities.
    features: (n, d) (segmentation: averaged over each image's valid pixels),
        (n, d, H, W) per pixel with ``features="pixel"``, or None with "none".
    """

    probs: np.ndarray
    features: np.ndarray | None


def predict(
    model: nn.Module,
    depth_m,
    valid,
    *,
    compute: Compute | None = None,
    batch_size: int = 256,
    features: str = "image",
) -> Predictions:
    """Class probabilities and penultimate features of ``model`` for (n, H, W) images.

    Args:
        features: "image" (per image; segmentation averages over valid pixels),
            "pixel" (segmentation: the full (n, d, H, W) maps), or "none".
        compute: device and precision of the forward passes (``iter_forward``).
    """
    if features not in FEATURE_MODES:
        raise ValueError(f"features must be one of {FEATURE_MODES}, got {features!r}.")
    probs, feats = [], []
    per_pixel = model.task == "segmentation"
    for _, p, f, v in iter_forward(model, depth_m, valid, compute=compute, batch_size=batch_size):
        probs.append(p.cpu().numpy())
        if features == "image" and per_pixel:
            f = pool_pixels(f, v)
        if features != "none":
            feats.append(f.cpu().numpy())
    if not probs:
        raise ValueError("depth_m holds no image to predict.")
    return Predictions(np.concatenate(probs), np.concatenate(feats) if feats else None)

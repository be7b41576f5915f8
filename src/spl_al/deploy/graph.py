"""A trained model with its input preprocessing in front: what an ONNX file holds.

``DeployGraph`` maps raw depth images to class logits and probabilities, so software
that runs the exported model needs no spl-al code:

    depth_m (B, H, W) float32, metres from the sensor; NaN, inf or <= 0 at a void
      -> valid = isfinite(depth_m) & (depth_m > 0)
      -> the model's input (``spl_al.models.model_input``: robustly standardised
         depth and validity, or range in metres and validity for PointNet++ and the
         range-aware U-Net)
      -> logits (B, C) or (B, C, H, W), probabilities = softmax over C

The standardisation's median becomes a sort while ``torch.onnx.export`` traces
(``spl_al.models.normalise._nanmedian``): the same values as training's.
"""

from __future__ import annotations

import torch
from torch import nn

from spl_al.models import model_input

INPUT_NAME = "depth_m"
OUTPUT_NAMES = ("logits", "probabilities")


def valid_of(depth_m: torch.Tensor) -> torch.Tensor:
    """The validity rule of a deployed model: finite and positive depth."""
    return torch.isfinite(depth_m) & (depth_m > 0)


class DeployGraph(nn.Module):
    """``model`` (eval mode) behind its preprocessing; ``forward(depth_m)`` ->
    ``(logits, probabilities)``."""

    def __init__(self, model: nn.Module) -> None:
        super().__init__()
        self.model = model
        self.eval()  # torch.onnx.export restores the wrapper's mode onto the model

    def forward(self, depth_m: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """depth_m (B, H, W) -> logits and softmax probabilities over the class axis 1."""
        valid = valid_of(depth_m)
        depth = torch.where(valid, depth_m, torch.nan)
        logits = self.model(model_input(self.model, depth, valid))[0]
        return logits, torch.softmax(logits, dim=1)

"""A U-Net-like encoder-decoder for dense per-pixel segmentation of range images.

Takes the (B, 2, H, W) input of ``to_input`` and returns ``(logits, features)``:
logits (B, C, H, W) and per-pixel penultimate features (B, d, H, W), the last
decoder map before the 1x1 classifier (d = width). Any H, W works: the input is
zero-padded (validity 0, i.e. void) to a multiple of 2**depth and the outputs are
cropped back. Upsampling is a stride-2 transposed convolution, whose CUDA backward
is deterministic (bilinear interpolation's is not).
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from spl_al.models.classifier import init_conv_bn
from spl_al.models.normalise import to_input
from spl_al.models.registry import register


def _double_conv(c_in: int, c_out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(c_in, c_out, 3, padding=1, bias=False),
        nn.BatchNorm2d(c_out),
        nn.ReLU(inplace=True),
        nn.Conv2d(c_out, c_out, 3, padding=1, bias=False),
        nn.BatchNorm2d(c_out),
        nn.ReLU(inplace=True),
    )


@register("segmentation", "unet", default=True)
class UNet(nn.Module):
    """U-Net (Ronneberger et al. 2015) with configurable width and depth.

    Args:
        n_classes: number of classes C.
        width: channels at full resolution; level k has width * 2**k channels.
        depth: number of 2x downsamplings (the bottleneck is at H / 2**depth).
        in_channels: input channels (2: depth and validity).
        absolute: take range in metres (``input_kind`` "range_m") and feed the network
            the standardised depth, validity, log range and row position (4 channels,
            ``_absolute_input``): a range image's classes differ in where they are
            (road low and near, building far, sky void), which the per-image
            standardisation alone removes (the default config turns it on). Off: the
            standardised input only.
    """

    task = "segmentation"

    def __init__(
        self,
        n_classes: int,
        width: int = 16,
        depth: int = 3,
        in_channels: int = 2,
        absolute: bool = False,
    ):
        super().__init__()
        if int(width) < 1 or int(depth) < 1:
            raise ValueError(f"width and depth must be >= 1, got {width}, {depth}.")
        self.absolute = bool(absolute)
        if self.absolute:
            # takes (range, validity) and adds log range and the row's position to the
            # standardised depth: where a return is, not only its shape, tells road
            # from building in a range image
            self.input_kind = "range_m"
            in_channels = 4
        self.n_classes = int(n_classes)
        self.depth = int(depth)
        widths = [width * 2**k for k in range(depth + 1)]
        self.down = nn.ModuleList([_double_conv(in_channels, widths[0])])
        self.down.extend(_double_conv(widths[k - 1], widths[k]) for k in range(1, depth + 1))
        self.up = nn.ModuleList(
            nn.ConvTranspose2d(widths[k], widths[k - 1], 2, stride=2) for k in range(depth, 0, -1)
        )
        self.merge = nn.ModuleList(
            _double_conv(2 * widths[k - 1], widths[k - 1]) for k in range(depth, 0, -1)
        )
        self.feature_dim = widths[0]
        self.head = nn.Conv2d(widths[0], self.n_classes, 1)
        self.init_weights()

    def init_weights(self) -> None:
        """Re-initialise convolutions and batch norms (He init, unit scale, zero shift)."""
        init_conv_bn(self)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """x (B, 2, H, W) -> logits (B, C, H, W), features (B, d, H, W)."""
        h, w = x.shape[-2:]
        features = self.decoder_maps(x)[-1][..., :h, :w]
        return self.head(features), features

    def decoder_maps(self, x: torch.Tensor) -> list[torch.Tensor]:
        """x (B, 2, H, W) -> the bottleneck's map and each decoder level's, coarsest
        first (widths width * 2**depth .. width), on the input zero-padded to a multiple
        of 2**depth."""
        h, w = x.shape[-2:]
        if self.absolute:
            x = _absolute_input(x)
        step = 2**self.depth
        pad_h, pad_w = (-h) % step, (-w) % step
        if pad_h or pad_w:
            x = F.pad(x, (0, pad_w, 0, pad_h))
        skips = []
        for k, block in enumerate(self.down):
            x = block(x if k == 0 else F.max_pool2d(x, 2))
            skips.append(x)
        x = skips.pop()
        maps = [x]
        for up, merge in zip(self.up, self.merge, strict=True):
            x = merge(torch.cat([skips.pop(), up(x)], dim=1))
            maps.append(x)
        return maps


def _absolute_input(x: torch.Tensor) -> torch.Tensor:
    """(B, 2, H, W) range in metres and validity -> (B, 4, H, W): standardised depth,
    validity, log(1 + range) / log(1 + 100 m), and the row's position in [-1, 1]."""
    range_m, valid = x[:, 0], x[:, 1] > 0
    z = to_input(torch.where(valid, range_m, torch.nan), valid)
    log_range = torch.where(valid, torch.log1p(range_m.clamp_min(0)) / math.log1p(100.0), 0.0)
    b, _, h, w = x.shape
    row = torch.linspace(-1.0, 1.0, h, device=x.device).view(1, 1, h, 1).expand(b, 1, h, w)
    return torch.cat([z, log_range[:, None], row], dim=1)

"""Image classifiers for SPL depth: ResNet-18 and a small, fast CNN.

Both take the (B, 2, H, W) input of ``to_input`` (normalised depth, validity) and
return ``(logits, features)`` from one forward pass: logits (B, C) and the
penultimate features (B, d), the global average of the last feature map.
Global pooling is a mean over (H, W) rather than ``AdaptiveAvgPool2d``, whose
CUDA backward is not deterministic.
"""

from __future__ import annotations

import torch
from torch import nn

from spl_al.models.registry import register

STEMS = ("imagenet", "cifar")


def _conv_bn(c_in: int, c_out: int, kernel: int, stride: int) -> list[nn.Module]:
    return [
        nn.Conv2d(c_in, c_out, kernel, stride=stride, padding=kernel // 2, bias=False),
        nn.BatchNorm2d(c_out),
    ]


def init_conv_bn(module: nn.Module) -> None:
    """He initialisation for convolutions, unit/zero batch norm, default linear layers."""
    for m in module.modules():
        if isinstance(m, nn.Conv2d | nn.ConvTranspose2d):
            nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            if m.bias is not None:
                nn.init.zeros_(m.bias)
        elif isinstance(m, nn.BatchNorm2d | nn.Linear):
            m.reset_parameters()


class BasicBlock(nn.Module):
    """Two 3x3 conv-BN layers with an identity (or 1x1 projection) shortcut."""

    def __init__(self, c_in: int, c_out: int, stride: int) -> None:
        super().__init__()
        self.body = nn.Sequential(
            *_conv_bn(c_in, c_out, 3, stride), nn.ReLU(inplace=True), *_conv_bn(c_out, c_out, 3, 1)
        )
        self.shortcut = (
            nn.Sequential(*_conv_bn(c_in, c_out, 1, stride))
            if stride != 1 or c_in != c_out
            else nn.Identity()
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """relu(body(x) + shortcut(x)): (B, C_in, H, W) -> (B, C_out, H', W')."""
        return torch.relu(self.body(x) + self.shortcut(x))


class _PooledClassifier(nn.Module):
    """Shared head: global average of the trunk's last feature map (the penultimate
    features, d channels), then a linear layer to the class logits."""

    task = "classification"

    def _add_head(self, feature_dim: int) -> None:
        self.feature_dim = feature_dim
        self.fc = nn.Linear(feature_dim, self.n_classes)
        self.init_weights()

    def init_weights(self) -> None:
        init_conv_bn(self)

    def trunk(self, x: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """x (B, 2, H, W) -> logits (B, C), features (B, d)."""
        features = self.trunk(x).mean(dim=(2, 3))
        return self.fc(features), features


@register("classification", "resnet18")
class ResNet(_PooledClassifier):
    """ResNet-18 (He et al. 2016) trained from scratch, with configurable width and stem.

    Args:
        n_classes: number of classes C.
        width: channels of the first stage; stages have width, 2w, 4w, 8w channels
            (64 is the standard ResNet-18, features d = 8 * width).
        stem: "imagenet" (7x7 stride-2 conv + 3x3 stride-2 max pool: 64x64 -> 16x16)
            or "cifar" (3x3 stride-1 conv, no pool: full resolution, ~16x the compute).
        blocks: residual blocks per stage; (2, 2, 2, 2) is ResNet-18.
        in_channels: input channels (2: depth and validity).
    """

    def __init__(
        self,
        n_classes: int,
        width: int = 64,
        stem: str = "imagenet",
        blocks: tuple[int, ...] = (2, 2, 2, 2),
        in_channels: int = 2,
    ) -> None:
        super().__init__()
        if stem not in STEMS:
            raise ValueError(f"stem must be one of {STEMS}, got {stem!r}.")
        if int(width) < 1 or not blocks or min(blocks) < 1:
            raise ValueError(
                f"width must be >= 1 and blocks non-empty positive, got {width}, {blocks}."
            )
        self.n_classes = int(n_classes)
        if stem == "imagenet":
            self.stem = nn.Sequential(
                *_conv_bn(in_channels, width, 7, 2),
                nn.ReLU(inplace=True),
                nn.MaxPool2d(3, stride=2, padding=1),
            )
        else:
            self.stem = nn.Sequential(*_conv_bn(in_channels, width, 3, 1), nn.ReLU(inplace=True))
        layers: list[nn.Module] = []
        c_in = width
        for stage, n_blocks in enumerate(blocks):
            c_out = width * 2**stage
            for b in range(n_blocks):
                layers.append(BasicBlock(c_in, c_out, 2 if (stage > 0 and b == 0) else 1))
                c_in = c_out
        self.stages = nn.Sequential(*layers)
        self._add_head(c_in)

    def trunk(self, x: torch.Tensor) -> torch.Tensor:
        """Feature maps before pooling: (B, 2, H, W) -> (B, d, H', W')."""
        return self.stages(self.stem(x))


@register("classification", "smallcnn", default=True)
class SmallCNN(_PooledClassifier):
    """A small, fast classifier for CPU runs: strided conv-BN-ReLU stages.

    Stage k has ``width * 2**k`` channels and halves the resolution (a 3x3 stride-2
    conv), followed by ``convs_per_stage - 1`` stride-1 convs; features are the
    global average of the last stage (d = width * 2**(stages-1)).

    Args:
        n_classes: number of classes C.
        width: channels of the first stage.
        stages: number of stages (resolution halves at each).
        convs_per_stage: convolutions per stage (>= 1).
        in_channels: input channels (2: depth and validity).
        input_pool: average the input over input_pool x input_pool blocks first (1:
            off). Photon noise is per pixel; averaging it before the first convolution
            keeps the network from fitting it when labels are few, and cuts the cost
            by input_pool^2.
        first_stride: stride of the first convolution (2 halves the resolution at
            once; 1 keeps it for the first stage).
    """

    def __init__(
        self,
        n_classes: int,
        *,
        width: int = 16,
        stages: int = 4,
        convs_per_stage: int = 1,
        in_channels: int = 2,
        input_pool: int = 1,
        first_stride: int = 2,
        dropout: float = 0.0,
    ) -> None:
        super().__init__()
        if int(width) < 1 or int(stages) < 1 or int(convs_per_stage) < 1:
            raise ValueError(
                f"width, stages and convs_per_stage must be >= 1, got {width}, {stages}, "
                f"{convs_per_stage}."
            )
        self.n_classes = int(n_classes)
        layers: list[nn.Module] = [nn.AvgPool2d(input_pool)] if input_pool > 1 else []
        c_in = in_channels
        for k in range(stages):
            c_out = width * 2**k
            for j in range(convs_per_stage):
                stride = (first_stride if k == 0 else 2) if j == 0 else 1
                layers += [*_conv_bn(c_in, c_out, 3, stride), nn.ReLU(inplace=True)]
                c_in = c_out
        self.body = nn.Sequential(*layers)
        self.dropout = nn.Dropout(dropout) if dropout > 0 else nn.Identity()
        self._add_head(c_in)

    def trunk(self, x: torch.Tensor) -> torch.Tensor:
        """Feature maps before pooling: (B, 2, H, W) -> (B, d, H', W')."""
        return self.body(x)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Logits (B, C) and penultimate features (B, d) of (B, 2, H, W) inputs."""
        features = self.trunk(x).mean(dim=(2, 3))
        return self.fc(self.dropout(features)), features

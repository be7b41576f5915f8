"""A self-supervised encoder of SPL images, learned without labels from their SIV views.

SimCLR's objective (Chen et al., ICML 2020) with the photon conditions as views: for
each frame of a batch, two of its G = M + 1 images (the observed image and its SIV
variants, ``spl_al.data.variants``) are drawn, each randomly shifted, and the encoder
learns to tell the pair apart from every other frame's images. What the embedding is
made invariant to is thus the photon condition the paper's method is about, plus a
small translation.

NT-Xent over a batch of B frames, z the 2B unit-length projections, tau the
temperature, p(i) the other view of i's frame::

    L = -1/(2B) sum_i log( exp(z_i . z_p(i) / tau) / sum_{k != i} exp(z_i . z_k / tau) )

Plain torch rather than a self-supervised library (lightly): the loss is the few
lines above, the encoder is this project's own SmallCNN, and the library would bring
its own training loop and dependencies for none of it.

The encoder never reads a label: ``train_encoder`` takes images alone. It trains in
fp32 on every CPU and GPU: one encoder carries every verdict of an embedding run, and
a bf16-trained one is another encoder (the verdicts of a run must not depend on the
CPU, see ``spl_al.training.precision``).
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import asdict, dataclass
from typing import TextIO

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from spl_al.models import model_input
from spl_al.models.classifier import SmallCNN
from spl_al.training.device import deterministic_algorithms, resolve_device
from spl_al.training.fit import ProgressLog, random_shift
from spl_al.training.recipe import known_fields
from spl_al.training.sgd import SGD


@dataclass(frozen=True)
class EncoderConfig:
    """How the encoder is built and trained (config ``embedding.encoder``).

    Attributes:
        width: channels of the SmallCNN's first stage; the embedding has 8 x width
            dimensions (its last stage, globally averaged).
        input_pool, first_stride, convs_per_stage: the SmallCNN's (``spl_al.models``).
        projection_dim: output of the projection head the loss reads (dropped after
            training: the embedding is the layer before it, as in SimCLR).
        steps: optimiser steps; batch_size: frames per step (2 views each).
        lr, momentum, weight_decay: SGD's, cosine schedule with a 5% warm-up.
        temperature: tau of NT-Xent.
        shift: largest random translation of a view, as a fraction of each side.
        seed: initialisation, batches, views and shifts.
    """

    width: int = 16
    input_pool: int = 2
    first_stride: int = 1
    convs_per_stage: int = 2
    projection_dim: int = 64
    steps: int = 300
    batch_size: int = 128
    lr: float = 0.3
    momentum: float = 0.9
    weight_decay: float = 5e-4
    temperature: float = 0.2
    shift: float = 0.125
    seed: int = 0

    @classmethod
    def from_dict(cls, values: dict | None) -> EncoderConfig:
        """From config ``embedding.encoder``; an unknown key is a one-sentence ValueError."""
        return cls(**known_fields(cls, values, "embedding.encoder: unknown keys"))

    def as_dict(self) -> dict:
        """JSON-ready fields."""
        return asdict(self)


class Encoder(nn.Module):
    """SmallCNN trunk -> embedding (B, d); ``project`` maps it to the loss's space."""

    def __init__(self, cfg: EncoderConfig) -> None:
        super().__init__()
        # n_classes is unused: the classifier head is never called
        self.backbone = SmallCNN(
            2,
            width=cfg.width,
            convs_per_stage=cfg.convs_per_stage,
            input_pool=cfg.input_pool,
            first_stride=cfg.first_stride,
        )
        d = self.backbone.feature_dim
        self.embedding_dim = d
        self.head = nn.Sequential(
            nn.Linear(d, d), nn.ReLU(inplace=True), nn.Linear(d, cfg.projection_dim)
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Embeddings (B, d) of (B, 2, H, W) inputs."""
        return self.backbone.trunk(x).mean(dim=(2, 3))

    def project(self, h: torch.Tensor) -> torch.Tensor:
        """Unit-length projections (B, projection_dim) of embeddings (B, d)."""
        return F.normalize(self.head(h), dim=1)


def nt_xent(z: torch.Tensor, temperature: float) -> torch.Tensor:
    """NT-Xent of 2B unit vectors whose rows i and i + B are the two views of a frame."""
    n = z.shape[0]
    b = n // 2
    sim = (z @ z.T) / temperature
    sim = sim.masked_fill(torch.eye(n, dtype=torch.bool, device=z.device), float("-inf"))
    positive = torch.cat([torch.arange(b, n), torch.arange(0, b)]).to(z.device)
    return F.cross_entropy(sim, positive)


def _views(x_all: torch.Tensor, frames: torch.Tensor, gen: torch.Generator) -> torch.Tensor:
    """Two distinct images of each frame: (2B, 2, H, W) from x_all (N, G, 2, H, W)."""
    g = x_all.shape[1]
    first = torch.randint(0, g, (len(frames),), generator=gen)
    # the second view is another image of the same frame (any image when G = 1)
    other = (first + torch.randint(1, max(g, 2), (len(frames),), generator=gen)) % g
    dev = x_all.device
    return torch.cat([x_all[frames, first.to(dev)], x_all[frames, other.to(dev)]])


def train_encoder(
    depth_m,
    valid,
    *,
    cfg: EncoderConfig,
    device: str | torch.device | None = None,
    log: str | os.PathLike | TextIO | None = None,
) -> tuple[Encoder, dict]:
    """Train an encoder on frames' views, without labels.

    Args:
        depth_m: (N, G, H, W) depth in metres, NaN at voids: N frames, each with its G
            = M + 1 images (observed first, then its SIV variants).
        valid: (N, G, H, W) bool validity.
        cfg: the recipe (``EncoderConfig``).
        device: "auto"/None, "cpu" or "cuda".
        log: where progress lines go (None: stderr).

    Returns:
        The encoder in eval mode, on the CPU, and its training record: steps, images
        per step, final loss, seconds and the forward-backward FLOPs per step.
    """
    depth_m = np.asarray(depth_m)
    if depth_m.ndim != 4 or np.shape(valid) != depth_m.shape:
        raise ValueError(
            f"depth_m and valid must both be (N, G, H, W), got {depth_m.shape} and "
            f"{np.shape(valid)}."
        )
    n, g, h, w = depth_m.shape
    if n < 2:
        raise ValueError(f"the encoder needs at least 2 frames to contrast, got {n}.")
    dev = resolve_device(device)
    started = time.perf_counter()
    gen = torch.Generator().manual_seed(int(cfg.seed))
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(int(cfg.seed))
        encoder = Encoder(cfg)
    x = model_input(encoder, depth_m.reshape(-1, h, w), np.asarray(valid).reshape(-1, h, w))
    x_all = x.view(n, g, *x.shape[1:]).to(dev)  # (N, G, 2, H, W)
    encoder.to(dev).train()
    opt = SGD(encoder.parameters(), lr=cfg.lr, momentum=cfg.momentum, weight_decay=cfg.weight_decay)
    batch = min(int(cfg.batch_size), n)
    max_px = (max(0, round(cfg.shift * h)), max(0, round(cfg.shift * w)))
    progress = ProgressLog(log)
    progress.line(
        f"encoder: {n} frames x {g} images {(h, w)}, {cfg.steps} steps of {batch} frames "
        f"(2 views each), embedding {encoder.embedding_dim}, device {dev}, fp32, seed {cfg.seed}"
    )
    order = torch.randperm(n, generator=gen)
    at = 0
    loss_value = float("nan")
    try:
        with deterministic_algorithms():
            for step in range(int(cfg.steps)):
                if at + batch > n:
                    order, at = torch.randperm(n, generator=gen), 0
                frames = order[at : at + batch].to(dev)
                at += batch
                views = _views(x_all, frames, gen)
                views, _ = random_shift(views, None, max_px, gen)
                lr = opt.param_groups[0]["lr"] = learning_rate(cfg, step)
                loss = nt_xent(encoder.project(encoder(views)), cfg.temperature)
                opt.zero_grad()
                loss.backward()
                opt.step()
                if step % 50 == 0 or step == cfg.steps - 1:
                    loss_value = float(loss.detach())
                    progress.line(f"step {step + 1}/{cfg.steps} loss {loss_value:.4f} lr {lr:.4f}")
    finally:
        progress.close()
    encoder.eval().cpu()
    record = {
        "steps": int(cfg.steps),
        "frames_per_step": batch,
        "images_per_step": 2 * batch,
        "final_loss": round(loss_value, 6),
        "train_seconds": round(time.perf_counter() - started, 3),
        "embedding_dim": int(encoder.embedding_dim),
        "flops_per_step": encoder_flops(encoder, (h, w)) * 2 * batch * 3,
    }
    return encoder, record


def learning_rate(cfg: EncoderConfig, step: int) -> float:
    """lr at ``step``: linear warm-up over the first 5% of steps, then cosine to 0."""
    warmup = max(1, round(0.05 * cfg.steps))
    lr = cfg.lr * min(1.0, (step + 1) / warmup)
    return lr * 0.5 * (1 + math.cos(math.pi * step / max(1, cfg.steps)))


def encoder_flops(encoder: Encoder, image_shape) -> int:
    """Multiply-adds x 2 of one image's forward pass through the backbone's convolutions
    (a backward pass costs about twice that: ``train_encoder`` counts 3x)."""
    flops = 0
    h, w = image_shape
    for layer in encoder.backbone.body:
        if isinstance(layer, nn.AvgPool2d):
            k = layer.kernel_size if isinstance(layer.kernel_size, int) else layer.kernel_size[0]
            h, w = h // k, w // k
        elif isinstance(layer, nn.Conv2d):
            s = layer.stride[0]
            h, w = (
                (h + 2 * layer.padding[0] - layer.kernel_size[0]) // s + 1,
                (w + 2 * layer.padding[1] - layer.kernel_size[1]) // s + 1,
            )
            k = layer.kernel_size[0] * layer.kernel_size[1] * layer.in_channels
            flops += 2 * k * layer.out_channels * h * w
    return int(flops)


@torch.no_grad()
def embed(encoder: Encoder, depth_m, valid, *, device=None, batch_size: int = 512) -> np.ndarray:
    """fp32 embeddings (n, d) of (n, H, W) images, whatever precision is configured."""
    dev = resolve_device(device)
    encoder.to(dev).eval()
    depth_m = np.asarray(depth_m)
    out = []
    for s in range(0, len(depth_m), batch_size):
        x = model_input(encoder, depth_m[s : s + batch_size], np.asarray(valid[s : s + batch_size]))
        out.append(encoder(x.to(dev)).float().cpu().numpy())
    encoder.cpu()
    if not out:
        return np.zeros((0, encoder.embedding_dim), dtype=np.float32)
    return np.concatenate(out).astype(np.float32)

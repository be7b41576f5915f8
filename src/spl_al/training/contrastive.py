"""A self-supervised encoder of SPL images, learned without labels.

SimCLR's objective (Chen et al., ICML 2020): for each frame of a batch two views are
made, and the encoder learns to tell the pair apart from every other frame's views.
What the views are is the ``objective``:

- ``siv``: two of the frame's G = M + 1 images (the observed image and its SIV
  variants, ``spl_al.data.variants``), each randomly shifted. The embedding is made
  invariant to the photon condition, which is what DUIS's inconsistency term reads:
  an encoder of this kind leaves that term little to find.
- ``generic``: two augmentations of the observed image alone (a random crop rescaled
  to the frame, a shift, Gaussian noise on the depth channel, pixel dropout), no SIV
  variant as a positive: the embedding keeps whatever the photon condition changes.

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
from spl_al.training.device import deterministic_algorithms, ieee_fp32, resolve_device
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
        objective: "siv" (a frame's SIV images are its positives) or "generic"
            (augmentations of the observed image alone); module docstring.
        crop: smallest side of a ``generic`` view's random crop, as a fraction.
        noise: standard deviation of a ``generic`` view's Gaussian noise, in units of
            the standardised depth channel.
        pixel_dropout: share of a ``generic`` view's pixels made voids.
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
    objective: str = "siv"
    crop: float = 0.7
    noise: float = 0.1
    pixel_dropout: float = 0.1
    seed: int = 0

    @classmethod
    def from_dict(cls, values: dict | None) -> EncoderConfig:
        """From config ``embedding.encoder`` (without its plan keys ``seeds`` and
        ``block``); an unknown key or objective is a one-sentence ValueError."""
        cfg = cls(**known_fields(cls, values, "embedding.encoder: unknown keys"))
        if cfg.objective not in OBJECTIVES:
            raise ValueError(
                f"embedding.encoder.objective must be one of {list(OBJECTIVES)}, "
                f"got {cfg.objective!r}."
            )
        return cfg

    def as_dict(self) -> dict:
        """JSON-ready fields."""
        return asdict(self)


OBJECTIVES = ("siv", "generic")
"""What a view pair is: two SIV images of a frame, or two augmentations of its observed one."""


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


def _generic_views(
    x_all: torch.Tensor, frames: torch.Tensor, gen: torch.Generator, cfg: EncoderConfig
) -> torch.Tensor:
    """Two augmentations of each frame's observed image: (2B, 2, H, W).

    Each view: a random square-scaled crop (side ``cfg.crop``..1 of the frame's, at a
    random place) resampled to the full frame by nearest neighbour (voids stay voids),
    Gaussian noise of sd ``cfg.noise`` on the valid pixels' depth, and pixel dropout
    (``cfg.pixel_dropout`` of the pixels set to voids: depth 0, validity 0).
    """
    x = x_all[frames, 0].repeat(2, 1, 1, 1)  # (2B, 2, H, W)
    n = x.shape[0]
    dev = x.device
    scale = cfg.crop + (1 - cfg.crop) * torch.rand(n, generator=gen)
    offset = (1 - scale)[:, None] * (2 * torch.rand(n, 2, generator=gen) - 1)
    theta = torch.zeros(n, 2, 3)
    theta[:, 0, 0] = theta[:, 1, 1] = scale
    theta[:, :, 2] = offset
    grid = F.affine_grid(theta.to(dev), list(x.shape), align_corners=False)
    x = F.grid_sample(x, grid, mode="nearest", padding_mode="zeros", align_corners=False)
    valid = x[:, 1:2]
    noise = torch.randn(x[:, :1].shape, generator=gen).to(dev) * float(cfg.noise)
    keep = (torch.rand(valid.shape, generator=gen) >= float(cfg.pixel_dropout)).to(dev)
    valid = valid * keep
    return torch.cat([(x[:, :1] + noise) * valid, valid], dim=1)


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
    started = time.perf_counter()
    encoder, x_all, gen = seeded_encoder(
        depth_m, valid, lambda: Encoder(cfg), seed=cfg.seed, device=device, what="frames"
    )
    n, g, _, h, w = x_all.shape
    dev = x_all.device
    # channels-last: oneDNN's convolutions run ~20% faster on it (docs/benchmarks.md)
    encoder.to(dev, memory_format=torch.channels_last).train()
    batch = min(int(cfg.batch_size), n)
    progress = ProgressLog(log)
    progress.line(
        f"encoder: {n} frames x {g} images {(h, w)}, {cfg.steps} steps of {batch} frames "
        f"(2 views each, {cfg.objective} objective), embedding {encoder.embedding_dim}, "
        f"device {dev}, fp32, seed {cfg.seed}"
    )
    try:
        final_loss = _fit(encoder, x_all, cfg, gen=gen, batch=batch, progress=progress)
    finally:
        progress.close()
    encoder.eval().to("cpu", memory_format=torch.contiguous_format)
    record = {
        "steps": int(cfg.steps),
        "frames_per_step": batch,
        "images_per_step": 2 * batch,
        "final_loss": round(final_loss, 6),
        "chance_loss": round(chance_loss(batch), 6),
        "train_seconds": round(time.perf_counter() - started, 3),
        "embedding_dim": int(encoder.embedding_dim),
        "flops_per_step": encoder_flops(encoder, (h, w)) * 2 * batch * 3,
        "trained_with": {
            "torch": torch.__version__,
            "device": device_name(dev),
            "threads": torch.get_num_threads(),
            "precision": "fp32",
            # the vector kernels torch ran (AVX512, AVX2, ...): a CPU capped at AVX2 by
            # ATEN_CPU_CAPABILITY trains other weights than the same CPU uncapped
            "cpu_capability": (
                None if dev.type == "cuda" else torch.backends.cpu.get_cpu_capability()
            ),
        },
    }
    return encoder, record


def seeded_encoder(depth_m, valid, build, *, seed: int, device, what: str):
    """The checked views of a self-supervised encoder's training, and the encoder.

    Checks that ``depth_m`` and ``valid`` are (N, G, H, W) with N >= 2 (``what`` names
    the N things in the refusal), sets fp32 matmuls, builds the module by ``build()``
    under torch's seed ``seed`` (the caller's random state is kept) and stacks its
    inputs (``model_input``).

    Returns:
        (encoder, x_all (N, G, C, H, W) on ``device``, the CPU generator of ``seed``).
    """
    depth_m = np.asarray(depth_m)
    if depth_m.ndim != 4 or np.shape(valid) != depth_m.shape:
        raise ValueError(
            f"depth_m and valid must both be (N, G, H, W), got {depth_m.shape} and "
            f"{np.shape(valid)}."
        )
    n, g, h, w = depth_m.shape
    if n < 2:
        raise ValueError(f"the encoder needs at least 2 {what} to contrast, got {n}.")
    dev = resolve_device(device)
    ieee_fp32()
    gen = torch.Generator().manual_seed(int(seed))
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(int(seed))
        encoder = build()
    x = model_input(encoder, depth_m.reshape(-1, h, w), np.asarray(valid).reshape(-1, h, w))
    return encoder, x.view(n, g, *x.shape[1:]).to(dev), gen


def _fit(encoder: Encoder, x_all: torch.Tensor, cfg: EncoderConfig, *, gen, batch, progress):
    """SGD on NT-Xent over ``cfg.steps`` batches of ``batch`` frames of ``x_all`` (N, G,
    2, H, W); returns the final loss, the mean over the last 10% of steps (one batch's
    loss is noisy)."""
    n, _, _, h, w = x_all.shape
    dev = x_all.device
    opt = SGD(encoder.parameters(), lr=cfg.lr, momentum=cfg.momentum, weight_decay=cfg.weight_decay)
    max_px = (max(0, round(cfg.shift * h)), max(0, round(cfg.shift * w)))
    order = torch.randperm(n, generator=gen)
    at = 0
    steps = int(cfg.steps)
    tail_from = steps - max(1, steps // 10)
    tail = torch.zeros((), device=dev)
    with deterministic_algorithms():
        for step in range(steps):
            if at + batch > n:
                order, at = torch.randperm(n, generator=gen), 0
            frames = order[at : at + batch].to(dev)
            at += batch
            if cfg.objective == "generic":
                views = _generic_views(x_all, frames, gen, cfg)
            else:
                views = _views(x_all, frames, gen)
            views, _ = random_shift(views, None, max_px, gen)
            views = views.contiguous(memory_format=torch.channels_last)
            lr = opt.param_groups[0]["lr"] = learning_rate(cfg, step)
            loss = nt_xent(encoder.project(encoder(views)), cfg.temperature)
            opt.zero_grad()
            loss.backward()
            opt.step()
            if step >= tail_from:
                tail += loss.detach()
            if step % 50 == 0 or step == steps - 1:
                progress.line(
                    f"step {step + 1}/{steps} loss {float(loss.detach()):.4f} lr {lr:.4f}"
                )
    return float(tail) / (steps - tail_from)


def chance_loss(frames: int) -> float:
    """NT-Xent of an encoder that tells nothing apart: ln(2B - 1) for B frames a batch
    (each view's softmax spreads evenly over the 2B - 1 others)."""
    return math.log(max(2 * int(frames) - 1, 2))


def device_name(dev: torch.device) -> str:
    """The CPU model or GPU name an encoder trained on (its card records it)."""
    if dev.type == "cuda":
        return torch.cuda.get_device_name(dev)
    import platform

    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


# An encoder's health, read without a label (docs/method.md, "Encoders that fail").
COLLAPSED_LOSS = 0.95
DOUBTFUL_LOSS = 0.70
COLLAPSED_RANK = 2.0
DOUBTFUL_RANK = 8.0


def effective_rank(embeddings) -> float:
    """Effective rank (Roy and Vetterli 2007) of (n, d) embeddings: exp of the entropy
    of their centred singular values normalised to sum 1, between 1 (every sample on
    one line: a collapsed encoder) and min(n, d)."""
    x = np.asarray(embeddings, dtype=np.float64)
    x = x - x.mean(axis=0)
    sv = np.linalg.svd(x, compute_uv=False)
    if sv.sum() <= 0:
        return 1.0
    p = sv / sv.sum()
    p = p[p > 0]
    return float(np.exp(-(p * np.log(p)).sum()))


def encoder_health(record: dict, embeddings) -> dict:
    """Label-free figures of a trained encoder and their verdict.

    ``record``: ``train_encoder``'s (its ``final_loss`` and ``chance_loss``);
    ``embeddings``: (n, d) of the training frames' observed images. Returns
    ``loss_ratio`` (final loss / chance), ``effective_rank`` and ``verdict``:
    "collapsed" when the loss ratio is at least ``COLLAPSED_LOSS`` or the effective
    rank below ``COLLAPSED_RANK``, "doubtful" at ``DOUBTFUL_LOSS`` / ``DOUBTFUL_RANK``,
    else "healthy", with ``failed``: the figures that set it.
    """
    ratio = float(record["final_loss"]) / float(record["chance_loss"])
    rank = effective_rank(embeddings)
    failed = []
    verdict = "healthy"
    for name, level in (
        ("collapsed", (COLLAPSED_LOSS, COLLAPSED_RANK)),
        ("doubtful", (DOUBTFUL_LOSS, DOUBTFUL_RANK)),
    ):
        reasons = []
        if ratio >= level[0]:
            reasons.append(f"final loss {ratio:.2f} of chance (at least {level[0]:.2f})")
        if rank < level[1]:
            reasons.append(f"effective rank {rank:.1f} (below {level[1]:g})")
        if reasons:
            verdict, failed = name, reasons
            break
    return {
        "loss_ratio": round(ratio, 4),
        "effective_rank": round(rank, 2),
        "verdict": verdict,
        "failed": failed,
    }


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
    encoder.to(dev, memory_format=torch.channels_last).eval()
    depth_m = np.asarray(depth_m)
    out = []
    for s in range(0, len(depth_m), batch_size):
        x = model_input(encoder, depth_m[s : s + batch_size], np.asarray(valid[s : s + batch_size]))
        x = x.to(dev).contiguous(memory_format=torch.channels_last)
        out.append(encoder(x).float().cpu().numpy())
    encoder.to("cpu", memory_format=torch.contiguous_format)
    if not out:
        return np.zeros((0, encoder.embedding_dim), dtype=np.float32)
    return np.concatenate(out).astype(np.float32)

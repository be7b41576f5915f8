"""A dense self-supervised encoder of range images: a feature per pixel, learned without labels.

Pixel contrast, in the line of DenseCL (Wang et al., CVPR 2021) and PixPro (Xie et al.,
CVPR 2021): each scan of a batch gives two views whose pixel correspondence is known;
the encoder (a U-Net trunk, ``spl_al.models.segmenter.UNet``) maps each view to a
feature per pixel; for P pixels of each scan sampled where both views see a return,
the projection of a pixel in one view has to find the same pixel of the other view
among every sampled pixel of the batch. NT-Xent over the 2BP unit projections z, p(i)
the same pixel in the other view, tau the temperature::

    L = -1/(2BP) sum_i log( exp(z_i . z_p(i) / tau) / sum_{k != i} exp(z_i . z_k / tau) )

What the two views are is the ``objective``:

- ``siv``: two of the scan's G = M + 1 images (the observed scan and its SIV variants,
  ``spl_al.data.variants``: pixel-aligned, so the same pixel sees the same surface
  under another photon condition), each a window of ``crop`` of the scan's width at
  its own column offset.
- ``generic``: two augmentations of the observed scan alone: the windows, Gaussian
  noise on the depth and pixel dropout (as ``contrastive``'s generic views).

A window keeps every row: a range image's rows are elevation angles, and where a
return lies (road low, sky void) is part of what tells classes apart.

The features a per-pixel probe reads are the trunk's last decoder map (``dense_features``,
``feature_dim`` = ``width`` per pixel); the projection head is dropped after training,
as in SimCLR. fp32 on every device, as ``contrastive``'s encoders.
"""

from __future__ import annotations

import os
import time
from dataclasses import asdict, dataclass
from typing import TextIO

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from spl_al.models import model_input
from spl_al.models.segmenter import UNet
from spl_al.training.contrastive import (
    chance_loss,
    device_name,
    learning_rate,
    nt_xent,
    seeded_encoder,
)
from spl_al.training.device import deterministic_algorithms, resolve_device
from spl_al.training.fit import ProgressLog
from spl_al.training.recipe import known_fields
from spl_al.training.sgd import SGD

DENSE_OBJECTIVES = ("siv", "generic")
DENSE_UNITS = ("pixel", "region")


@dataclass(frozen=True)
class DenseEncoderConfig:
    """How the dense encoder is built and trained.

    Attributes:
        width, depth: the U-Net trunk's (``feature_dim`` = width features a pixel).
        projection_dim: output of the projection head the loss reads.
        steps: optimiser steps; batch_size: scans per step (two views each).
        pixels: pixels sampled per scan and step (P).
        lr, momentum, weight_decay: SGD's, cosine schedule with a 5% warm-up.
        temperature: tau of NT-Xent.
        crop: width of a view's window, as a fraction of the scan's width.
        objective: "siv" or "generic" (module docstring).
        unit: what is contrasted: "pixel" (P sampled pixels a scan) or "region" (the
            mean feature of each region of ``scan_regions``, DetCon's unit).
        region_cell: (rows, cols) of a region's grid cell; region_depth_step: the
            relative depth step that splits a cell into regions.
        noise: sd of a generic view's depth noise, in metres.
        pixel_dropout: share of a generic view's pixels made voids.
        seed: initialisation, batches, views and sampled pixels.
    """

    width: int = 32
    depth: int = 3
    projection_dim: int = 64
    steps: int = 300
    batch_size: int = 16
    pixels: int = 64
    lr: float = 0.1
    momentum: float = 0.9
    weight_decay: float = 5e-4
    temperature: float = 0.2
    crop: float = 0.5
    objective: str = "siv"
    unit: str = "pixel"
    region_cell: tuple = (8, 16)
    region_depth_step: float = 0.15
    noise: float = 0.1
    pixel_dropout: float = 0.1
    seed: int = 0

    @classmethod
    def from_dict(cls, values: dict | None) -> DenseEncoderConfig:
        """From a config mapping; an unknown key or objective is a one-sentence ValueError."""
        cfg = cls(**known_fields(cls, values, "dense encoder: unknown keys"))
        if cfg.objective not in DENSE_OBJECTIVES:
            raise ValueError(
                f"dense encoder objective must be one of {list(DENSE_OBJECTIVES)}, "
                f"got {cfg.objective!r}."
            )
        if cfg.unit not in DENSE_UNITS:
            raise ValueError(
                f"dense encoder unit must be one of {list(DENSE_UNITS)}, got {cfg.unit!r}."
            )
        if not 0 < cfg.crop <= 1:
            raise ValueError(f"dense encoder crop must be in (0, 1], got {cfg.crop!r}.")
        return cfg

    def as_dict(self) -> dict:
        """JSON-ready fields."""
        return asdict(self)


class DenseEncoder(nn.Module):
    """U-Net trunk -> features (B, d, H, W); ``project`` maps sampled ones to the loss's space."""

    def __init__(self, cfg: DenseEncoderConfig) -> None:
        super().__init__()
        # n_classes is unused: the U-Net's 1x1 head is never called
        self.trunk = UNet(2, width=cfg.width, depth=cfg.depth, absolute=True)
        self.input_kind = self.trunk.input_kind
        d = self.trunk.feature_dim
        self.feature_dim = d
        self.head = nn.Sequential(
            nn.Linear(d, d), nn.ReLU(inplace=True), nn.Linear(d, cfg.projection_dim)
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Features (B, d, H, W) of (B, 2, H, W) inputs (range in metres, validity)."""
        return self.trunk(x)[1]

    @torch.no_grad()
    def levels(self, x: torch.Tensor, n: int) -> torch.Tensor:
        """The ``n`` finest decoder maps (the bottleneck's the coarsest), upsampled to the
        input (nearest) and stacked finest first: (B, their widths summed, H, W), the
        context of coarser scales for a linear probe; n = 1 is ``forward``."""
        h, w = x.shape[-2:]
        maps = self.trunk.decoder_maps(x)[::-1][: max(1, int(n))]
        size = maps[0].shape[-2:]
        full = [F.interpolate(m, size=size, mode="nearest") for m in maps]
        return torch.cat(full, dim=1)[..., :h, :w]

    def project(self, f: torch.Tensor) -> torch.Tensor:
        """Unit-length projections (n, projection_dim) of features (n, d)."""
        return F.normalize(self.head(f), dim=1)


def _windows(x: torch.Tensor, start: torch.Tensor, width: int) -> torch.Tensor:
    """Columns start[b] .. start[b] + width of each image of x (B, C, H, W)."""
    cols = start[:, None] + torch.arange(width, device=x.device)[None]  # (B, width)
    idx = cols[:, None, None, :].expand(x.shape[0], x.shape[1], x.shape[2], width)
    return torch.gather(x, 3, idx)


def _pair(x_all: torch.Tensor, scans: torch.Tensor, gen: torch.Generator, cfg: DenseEncoderConfig):
    """Two views of each scan and where they overlap.

    Returns (view_a, view_b, start_a, start_b, width): views (B, 2, H, width) and the
    column of the scan each window starts at.
    """
    b = len(scans)
    g, w = x_all.shape[1], x_all.shape[-1]
    width = max(1, min(w, round(cfg.crop * w)))
    if cfg.objective == "siv":
        first = torch.randint(0, g, (b,), generator=gen)
        other = (first + torch.randint(1, max(g, 2), (b,), generator=gen)) % g
        a_full, b_full = x_all[scans, first.to(x_all.device)], x_all[scans, other.to(x_all.device)]
    else:
        a_full = b_full = x_all[scans, 0]
    # window b starts within half a window of a's: at least half of each overlaps
    start_a = torch.randint(0, w - width + 1, (b,), generator=gen)
    lo = torch.clamp(start_a - width // 2, min=0)
    hi = torch.clamp(start_a + width // 2, max=w - width)
    start_b = lo + (torch.rand(b, generator=gen) * (hi - lo + 1).float()).long().clamp_max(hi - lo)
    dev = x_all.device
    view_a = _windows(a_full, start_a.to(dev), width)
    view_b = _windows(b_full, start_b.to(dev), width)
    if cfg.objective == "generic":
        view_a, view_b = (_augment(v, gen, cfg) for v in (view_a, view_b))
    return view_a, view_b, start_a, start_b, width


def _augment(x: torch.Tensor, gen: torch.Generator, cfg: DenseEncoderConfig) -> torch.Tensor:
    """Gaussian depth noise (metres) on the valid pixels and pixel dropout."""
    valid = x[:, 1:2]
    noise = torch.randn(valid.shape, generator=gen).to(x.device) * float(cfg.noise)
    keep = (torch.rand(valid.shape, generator=gen) >= float(cfg.pixel_dropout)).to(x.device)
    valid = valid * keep
    return torch.cat([(x[:, :1] + noise).clamp_min(0) * valid, valid], dim=1)


def _sample_pixels(view_a, view_b, *, start_a, start_b, width, n_pixels, gen):
    """P pixels of each scan valid in both views: flat indices into each view's (H, width).

    Returns (rows b of the batch, index in view a, index in view b), each (B * P,),
    drawn without replacement; a scan with fewer shared valid pixels than P repeats
    some, one with none gives none.
    """
    b = view_a.shape[0]
    offset = (start_b - start_a).tolist()
    batch, in_a, in_b = [], [], []
    for i in range(b):
        d = offset[i]  # column c of view a is column c - d of view b
        lo, hi = max(0, d), min(width, width + d)
        both = (view_a[i, 1, :, lo:hi] > 0) & (view_b[i, 1, :, lo - d : hi - d] > 0)
        rows, cols = torch.nonzero(both.cpu(), as_tuple=True)
        if rows.numel() == 0:
            continue
        k = rows.numel()
        pick = (  # without replacement where the scan has P such pixels
            torch.randperm(k, generator=gen)[:n_pixels]
            if k >= n_pixels
            else torch.randint(0, k, (n_pixels,), generator=gen)
        )
        r, c = rows[pick], cols[pick] + lo
        batch.append(torch.full((n_pixels,), i))
        in_a.append(r * width + c)
        in_b.append(r * width + (c - d))
    if not batch:
        empty = torch.zeros(0, dtype=torch.long)
        return empty, empty, empty
    return torch.cat(batch), torch.cat(in_a), torch.cat(in_b)


def scan_regions(depth_m, valid, cell=(8, 16), depth_step: float = 0.15) -> np.ndarray:
    """An over-segmentation of each scan without labels: (N, H, W) int64 region ids,
    numbered 0.. within each scan, -1 at voids.

    A region is the valid pixels of one grid cell (``cell`` rows x cols) whose depths
    fall in one step of ``depth_step`` in log depth (a 15% step by default): a cell
    crossing a depth edge (a car before a wall) is split at the edge, while a surface
    stays in few regions.
    """
    depth = np.asarray(depth_m, dtype=np.float64)
    mask = np.asarray(valid, dtype=bool) & np.isfinite(depth) & (depth > 0)
    n, h, w = depth.shape
    rows, cols = np.mgrid[0:h, 0:w]
    cell_id = (rows // int(cell[0])) * (-(-w // int(cell[1]))) + cols // int(cell[1])
    step = np.log1p(float(depth_step))
    bins = np.floor(np.log(np.where(mask, depth, 1.0)) / step).astype(np.int64)
    key = cell_id[None].astype(np.int64) * 100_000 + (bins - bins.min())
    out = np.full((n, h, w), -1, dtype=np.int64)
    for i in range(n):
        _, ids = np.unique(key[i][mask[i]], return_inverse=True)
        out[i][mask[i]] = ids
    return out


def _region_means(feats, view, region_window, overlap, min_pixels: int):
    """Mean feature of each region over its valid pixels in the overlap, per scan.

    Args: feats (B, d, H, width) of one view; view (B, 2, H, width) its input;
    region_window (B, H, width) region ids seen by it (-1 none); overlap (B, width) its
    columns the other view sees too. Returns a list of B (sums (R_i, d), counts (R_i,)).
    """
    keep = overlap[:, None, :] & (view[:, 1] > 0) & (region_window >= 0)
    ids = torch.where(keep, region_window, -1).flatten(1)  # (B, H * width)
    flat = feats.flatten(2)  # (B, d, H * width)
    out = []
    for i in range(ids.shape[0]):
        n_regions = int(ids[i].max()) + 1
        if n_regions <= 0:
            out.append((flat.new_zeros(0, flat.shape[1]), flat.new_zeros(0)))
            continue
        # a one-hot product: deterministic on every device, unlike a scatter-add
        onehot = F.one_hot(ids[i].clamp_min(0), n_regions).to(flat.dtype)
        onehot = onehot * (ids[i] >= 0)[:, None]
        out.append((onehot.T @ flat[i].T, onehot.sum(0)))
    return out


def _region_pairs(feats, view_a, view_b, *, regions, start_a, start_b, width, min_pixels=4):
    """(fa, fb): the mean features (n, d) of the regions both views hold at least
    ``min_pixels`` valid pixels of, in the same order."""
    b = view_a.shape[0]
    dev = feats.device
    d = (start_b - start_a).to(dev)
    cols = torch.arange(width, device=dev)[None]
    overlap_a = (cols >= d[:, None]) & (cols < width + d[:, None])
    overlap_b = (cols >= -d[:, None]) & (cols < width - d[:, None])
    ra = _windows(regions[:, None], start_a.to(dev), width)[:, 0]
    rb = _windows(regions[:, None], start_b.to(dev), width)[:, 0]
    mean_a = _region_means(feats[:b], view_a, ra, overlap_a, min_pixels)
    mean_b = _region_means(feats[b:], view_b, rb, overlap_b, min_pixels)
    fa, fb = [], []
    for (sa, ca), (sb, cb) in zip(mean_a, mean_b, strict=True):
        r = min(len(ca), len(cb))
        good = (ca[:r] >= min_pixels) & (cb[:r] >= min_pixels)
        fa.append(sa[:r][good] / ca[:r][good, None])
        fb.append(sb[:r][good] / cb[:r][good, None])
    return torch.cat(fa), torch.cat(fb)


def train_dense_encoder(
    depth_m,
    valid,
    *,
    cfg: DenseEncoderConfig,
    device: str | torch.device | None = None,
    log: str | os.PathLike | TextIO | None = None,
) -> tuple[DenseEncoder, dict]:
    """Train a dense encoder on scans' views, without labels.

    Args:
        depth_m: (N, G, H, W) range in metres, NaN at voids: N scans, each with its G =
            M + 1 images (observed first, then its SIV variants).
        valid: (N, G, H, W) bool validity.
        cfg: the recipe (``DenseEncoderConfig``).
        device: "auto"/None, "cpu" or "cuda".
        log: where progress lines go (None: stderr).

    Returns:
        The encoder in eval mode on the CPU, and its record: steps, pixels per step,
        final and chance loss, seconds, feature_dim, where it trained.
    """
    started = time.perf_counter()
    encoder, x_all, gen = seeded_encoder(
        depth_m, valid, lambda: DenseEncoder(cfg), seed=cfg.seed, device=device, what="scans"
    )
    n, g, _, h, w = x_all.shape
    dev = x_all.device
    depth_m = np.asarray(depth_m)
    regions = None
    if cfg.unit == "region":  # of the observed scans: every view of a scan shares them
        ids = scan_regions(
            depth_m[:, 0], np.asarray(valid)[:, 0], cfg.region_cell, cfg.region_depth_step
        )
        regions = torch.from_numpy(ids).to(dev)
    # channels-last: oneDNN's convolutions run faster on it (docs/benchmarks.md)
    encoder.to(dev, memory_format=torch.channels_last).train()
    batch = min(int(cfg.batch_size), n)
    progress = ProgressLog(log)
    progress.line(
        f"dense encoder: {n} scans x {g} images {(h, w)}, {cfg.steps} steps of {batch} scans "
        f"x {cfg.pixels} pixels ({cfg.objective} views), {encoder.feature_dim} features a "
        f"pixel, device {dev}, fp32, seed {cfg.seed}"
    )
    try:
        final_loss, pairs = _fit(
            encoder, x_all, regions, cfg, gen=gen, batch=batch, progress=progress
        )
    finally:
        progress.close()
    encoder.eval().to("cpu", memory_format=torch.contiguous_format)
    record = {
        "steps": int(cfg.steps),
        "scans_per_step": batch,
        "pixels_per_step": pairs,
        "final_loss": round(final_loss, 6),
        "chance_loss": round(chance_loss(pairs), 6),
        "train_seconds": round(time.perf_counter() - started, 3),
        "feature_dim": int(encoder.feature_dim),
        "trained_with": {
            "torch": torch.__version__,
            "device": device_name(dev),
            "threads": torch.get_num_threads(),
            "precision": "fp32",
        },
    }
    return encoder, record


def _fit(encoder, x_all, regions, cfg: DenseEncoderConfig, *, gen, batch, progress):
    """SGD on the pixel NT-Xent; returns (mean loss over the last 10% of steps, the
    pixels a step contrasts)."""
    n = x_all.shape[0]
    dev = x_all.device
    opt = SGD(encoder.parameters(), lr=cfg.lr, momentum=cfg.momentum, weight_decay=cfg.weight_decay)
    order = torch.randperm(n, generator=gen)
    at, steps = 0, int(cfg.steps)
    tail_from = steps - max(1, steps // 10)
    tail, pairs = 0.0, 0
    with deterministic_algorithms():
        for step in range(steps):
            if at + batch > n:
                order, at = torch.randperm(n, generator=gen), 0
            scans = order[at : at + batch].to(dev)
            at += batch
            view_a, view_b, start_a, start_b, width = _pair(x_all, scans, gen, cfg)
            if regions is None:
                rows, in_a, in_b = _sample_pixels(
                    view_a,
                    view_b,
                    start_a=start_a,
                    start_b=start_b,
                    width=width,
                    n_pixels=int(cfg.pixels),
                    gen=gen,
                )
                if rows.numel() < 2:
                    continue
            views = torch.cat([view_a, view_b]).contiguous(memory_format=torch.channels_last)
            feats = encoder(views)  # (2B, d, H, width)
            b = view_a.shape[0]
            if regions is None:
                flat = feats.flatten(2)  # (2B, d, H * width)
                rows, in_a, in_b = rows.to(dev), in_a.to(dev), in_b.to(dev)
                fa, fb = flat[rows, :, in_a], flat[rows + b, :, in_b]
            else:
                fa, fb = _region_pairs(
                    feats,
                    view_a,
                    view_b,
                    regions=regions[scans],
                    start_a=start_a,
                    start_b=start_b,
                    width=width,
                )
                if len(fa) < 2:
                    continue
            z = encoder.project(torch.cat([fa, fb]))
            lr = opt.param_groups[0]["lr"] = learning_rate(cfg, step)
            loss = nt_xent(z, cfg.temperature)
            opt.zero_grad()
            loss.backward()
            opt.step()
            pairs = int(fa.shape[0])
            if step >= tail_from:
                tail += float(loss.detach())
            if step % 50 == 0 or step == steps - 1:
                progress.line(
                    f"step {step + 1}/{steps} loss {float(loss.detach()):.4f} lr {lr:.4f}"
                )
    return tail / (steps - tail_from), pairs


@torch.no_grad()
def dense_features(
    encoder: DenseEncoder,
    depth_m,
    valid,
    *,
    device=None,
    batch_size: int = 64,
    levels: int = 1,
) -> np.ndarray:
    """fp32 features (n, H, W, d) of every pixel of (n, H, W) scans: the last decoder
    map, and the next ``levels - 1`` coarser ones (``DenseEncoder.levels``)."""
    dev = resolve_device(device)
    encoder.to(dev, memory_format=torch.channels_last).eval()
    depth_m = np.asarray(depth_m)
    out = []
    for s in range(0, len(depth_m), batch_size):
        x = model_input(encoder, depth_m[s : s + batch_size], np.asarray(valid[s : s + batch_size]))
        f = encoder.levels(x.to(dev).contiguous(memory_format=torch.channels_last), levels)
        out.append(f.permute(0, 2, 3, 1).float().cpu().numpy())
    encoder.to("cpu", memory_format=torch.contiguous_format)
    if not out:
        return np.zeros((0, *depth_m.shape[1:], encoder.feature_dim), dtype=np.float32)
    return np.concatenate(out).astype(np.float32)

"""Label-free pretraining on the whole training pool: condition-contrastive learning.

A deep model trained from scratch on 20 labeled groups has too little to learn from;
the unlabeled pool is there in every round, and its groups already hold what a photon
budget does to a scene: each observed image and its SIV variants show the same scene
under different conditions. Pretraining pulls the features of two images of the same
group together and pushes other groups' apart (SimCLR's NT-Xent loss, Chen et al.
2020), with random shifts (and flips) on top:

    L = -1/2B sum_i [ log softmax_j( z_i . z_j / T )[pos(i)] ],  z = g(phi(x)) / |g(phi(x))|

over the 2B views of a batch of B groups, phi the model's penultimate features, g a
two-layer projection head (discarded afterwards) and T the temperature. No label is
read, so every method and round may start from these weights; a round then trains
(fine-tunes) on its labeled groups as before. The weights depend on the seed, the
data and the config only, so all methods of a seed share them (paired comparisons).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, fields

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from spl_al.models import reset_parameters, to_input
from spl_al.training.config import deterministic_algorithms, resolve_device
from spl_al.training.fit import ProgressLog, random_shift


@dataclass(frozen=True)
class PretrainConfig:
    """How to pretrain (module docstring).

    Attributes:
        steps: optimiser steps.
        batch_groups: groups per step (2 views each).
        lr, momentum, weight_decay: SGD with a cosine schedule.
        temperature: T of the NT-Xent loss.
        projection_dim: output size of the projection head.
        shift: random-shift augmentation (fraction of the image size).
        hflip: random horizontal flips.
        tilt: largest ramp added to the normalised depth across the image.
        drop: fraction of valid pixels made voids at random.
    """

    steps: int = 600
    batch_groups: int = 128
    lr: float = 0.1
    momentum: float = 0.9
    weight_decay: float = 5e-4
    temperature: float = 0.2
    projection_dim: int = 64
    shift: float = 0.125
    hflip: bool = True
    tilt: float = 1.0
    drop: float = 0.2

    def __post_init__(self) -> None:
        for name in ("steps", "batch_groups", "projection_dim"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"PretrainConfig.{name} must be an integer >= 1, got {v!r}.")
        for name in ("lr", "momentum", "weight_decay", "temperature"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not v >= 0:
                raise ValueError(f"PretrainConfig.{name} must be a number >= 0, got {v!r}.")
        if not 0 <= self.shift < 0.5:
            raise ValueError(f"PretrainConfig.shift must be in [0, 0.5), got {self.shift!r}.")

    @classmethod
    def from_dict(cls, params) -> PretrainConfig:
        params = dict(params or {})
        unknown = sorted(set(params) - {f.name for f in fields(cls)})
        if unknown:
            raise ValueError(
                f"unknown pretrain keys {unknown}; expected some of {sorted(asdict(cls()))}."
            )
        return cls(**params)


def nt_xent(z1: torch.Tensor, z2: torch.Tensor, temperature: float) -> torch.Tensor:
    """NT-Xent loss of two (B, k) batches of L2-normalised embeddings, row i of z1 and
    row i of z2 being the positive pair."""
    z = torch.cat([z1, z2])
    sim = z @ z.T / temperature
    b = len(z1)
    sim = sim.masked_fill(torch.eye(2 * b, dtype=torch.bool, device=z.device), -1e9)
    target = torch.cat([torch.arange(b, 2 * b), torch.arange(0, b)]).to(z.device)
    logp = F.log_softmax(sim, dim=1)
    return -logp.gather(1, target[:, None]).mean()


def _photometric(x: torch.Tensor, cfg: PretrainConfig, gen: torch.Generator) -> torch.Tensor:
    """Break the shortcuts that identify a group without its shape: a random tilt (a
    linear ramp added to the normalised depth, as a slanted mount would), a random
    depth scale, and random extra voids (``drop`` of the valid pixels)."""
    b, _, h, w = x.shape
    z, v = x[:, 0], x[:, 1]
    slope = (torch.rand(b, 2, generator=gen) * 2 - 1).to(x.device) * cfg.tilt
    rows = torch.linspace(-1, 1, h, device=x.device).view(1, h, 1)
    cols = torch.linspace(-1, 1, w, device=x.device).view(1, 1, w)
    scale = torch.exp((torch.rand(b, generator=gen) * 2 - 1) * 0.3).to(x.device).view(b, 1, 1)
    keep = (torch.rand(b, h, w, generator=gen) >= cfg.drop).to(x.device)
    v = v * keep
    z = (z * scale + slope[:, 0].view(b, 1, 1) * rows + slope[:, 1].view(b, 1, 1) * cols) * v
    return torch.stack([z.clamp(-4, 4), v], dim=1)


def pretrain(
    model: nn.Module,
    depth_m,
    valid,
    cfg: PretrainConfig | dict | None = None,
    seed: int = 0,
    device=None,
    log=None,
) -> nn.Module:
    """Pretrain ``model``'s trunk on groups of images without labels; returns the model
    (re-initialised from ``seed`` first; its classifier layer is left as initialised).

    Args:
        model: from ``spl_al.models.build_model`` (classification).
        depth_m, valid: (n, G, H, W) groups, G >= 1 (with G = 1 the two views differ by
            augmentation only).
    """
    cfg = cfg if isinstance(cfg, PretrainConfig) else PretrainConfig.from_dict(cfg)
    depth_m, valid = np.asarray(depth_m), np.asarray(valid)
    if depth_m.ndim != 4 or valid.shape != depth_m.shape or len(depth_m) < 2:
        raise ValueError(
            f"depth_m and valid must be (n, G, H, W) with n >= 2, got {depth_m.shape}, {valid.shape}."
        )
    n, g, h, w = depth_m.shape
    dev = resolve_device(device)
    x_all = to_input(depth_m.reshape(n * g, h, w), valid.reshape(n * g, h, w)).to(dev)
    x_all = x_all.view(n, g, 2, h, w)
    reset_parameters(model, seed)
    torch.manual_seed(int(seed))  # the projection head's initialisation
    head = nn.Sequential(
        nn.Linear(model.feature_dim, model.feature_dim),
        nn.ReLU(inplace=True),
        nn.Linear(model.feature_dim, cfg.projection_dim),
    )
    model.to(dev)
    head.to(dev)
    params = list(model.parameters()) + list(head.parameters())
    opt = torch.optim.SGD(params, lr=cfg.lr, momentum=cfg.momentum, weight_decay=cfg.weight_decay)
    gen = torch.Generator().manual_seed(int(seed))
    batch = min(cfg.batch_groups, n)
    shift_px = (round(cfg.shift * h), round(cfg.shift * w))
    progress = ProgressLog(log)
    progress.line(f"pretrain on {n} groups x {g} images {(h, w)}, {cfg.steps} steps, batch {batch}")
    start = time.perf_counter()
    model.train()
    head.train()
    perm, pos = torch.randperm(n, generator=gen), 0
    try:
        with deterministic_algorithms():
            for step in range(cfg.steps):
                if pos + batch > n:
                    perm, pos = torch.randperm(n, generator=gen), 0
                idx = perm[pos : pos + batch]
                pos += batch
                # two different images of each group (the same one when G = 1)
                a = torch.randint(0, g, (batch,), generator=gen)
                b = (a + torch.randint(1, max(g, 2), (batch,), generator=gen)) % g
                views = []
                for pick in (a, b):
                    x = x_all[idx.to(dev), pick.to(dev)]
                    if cfg.hflip:
                        flip = (torch.rand(batch, generator=gen) < 0.5).to(dev)
                        x = torch.where(flip.view(-1, 1, 1, 1), x.flip(-1), x)
                    if max(shift_px) > 0:
                        x, _ = random_shift(x, None, shift_px, gen)
                    views.append(_photometric(x, cfg, gen))
                lr = cfg.lr * 0.5 * (1 + math.cos(math.pi * step / cfg.steps))
                for group in opt.param_groups:
                    group["lr"] = lr
                _, feats = model(torch.cat(views))
                z = F.normalize(head(feats), dim=1)
                loss = nt_xent(z[:batch], z[batch:], cfg.temperature)
                opt.zero_grad(set_to_none=True)
                loss.backward()
                opt.step()
                if step % 100 == 0 or step == cfg.steps - 1:
                    progress.line(
                        f"step {step + 1}/{cfg.steps} loss {loss.item():.4f} lr {lr:.4g} "
                        f"{time.perf_counter() - start:.1f}s"
                    )
    finally:
        progress.close()
    model.eval()
    return model

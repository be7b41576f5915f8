"""Fit a classifier or segmenter with SGD, deterministically from a seed."""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from dataclasses import dataclass
from typing import TextIO

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from spl_al.data.dataset import TASKS
from spl_al.label_codes import IGNORE_INDEX
from spl_al.models import model_input, reset_parameters, seed_own_draws, training_outputs
from spl_al.training.compute import LOCAL, Compute
from spl_al.training.device import deterministic_algorithms
from spl_al.training.precision import LossScaler, autocast
from spl_al.training.recipe import TrainConfig
from spl_al.training.sgd import SGD


def masked_cross_entropy(
    logits: torch.Tensor, target: torch.Tensor, class_weight: torch.Tensor | None = None
) -> torch.Tensor:
    """Weighted mean of -log softmax(logits)[target] over units whose target is not
    IGNORE_INDEX: sum_u w[y_u] nll_u / sum_u w[y_u] (w = 1 without ``class_weight``).

    Args:
        logits: (B, C) or (B, C, H, W).
        target: (B,) or (B, H, W) int64 class indices, IGNORE_INDEX where ignored.
        class_weight: (C,) weight of each class, or None.

    Written with a one-hot mask instead of ``F.cross_entropy`` because CUDA's NLL
    loss kernels are not deterministic; returns 0 when every unit is ignored.
    """
    logp = F.log_softmax(logits.float(), dim=1)
    classes = torch.arange(logits.shape[1], device=logits.device)
    onehot = target.unsqueeze(1) == classes.view(1, -1, *([1] * (logits.ndim - 2)))
    nll = -torch.where(onehot, logp, 0.0).sum(dim=1)
    if class_weight is None:
        kept = (target != IGNORE_INDEX).sum()
        return nll.sum() / kept.clamp_min(1)
    w = class_weight.to(logp.device, logp.dtype)
    unit_w = torch.where(onehot, w.view(1, -1, *([1] * (logits.ndim - 2))), 0.0).sum(dim=1)
    return (unit_w * nll).sum() / unit_w.sum().clamp_min(1e-12)


def balanced_class_weights(targets: torch.Tensor, n_classes: int, power: float) -> torch.Tensor:
    """(C,) weights n_c^-power of the classes in ``targets`` (IGNORE_INDEX left out),
    scaled so that the mean weight per unit is 1; classes absent from it get 0."""
    kept = targets[targets != IGNORE_INDEX].flatten()
    counts = torch.bincount(kept, minlength=n_classes)[:n_classes].double()
    w = torch.where(counts > 0, counts.clamp_min(1) ** -float(power), 0.0)
    return (w * counts.sum() / (w * counts).sum().clamp_min(1e-12)).float()


def check_targets(task: str, targets, *, n_images: int, image_shape, n_classes: int) -> np.ndarray:
    """Validate targets: (n,) class indices, or (n, H, W) masks with IGNORE_INDEX; int64 copy."""
    t = np.asarray(targets)
    expected = (n_images,) if task == "classification" else (n_images, *image_shape)
    if t.shape != expected:
        raise ValueError(f"targets must have shape {expected} for {task}, got {t.shape}.")
    if t.size and not np.issubdtype(t.dtype, np.integer):
        raise ValueError(f"targets must be integer class indices, got dtype {t.dtype}.")
    t = t.astype(np.int64)
    ok = (t >= 0) & (t < n_classes)
    if task == "segmentation":
        ok |= t == IGNORE_INDEX
    if not ok.all():
        bad = t[~ok][0]
        raise ValueError(
            f"targets must lie in [0, {n_classes})"
            + (f" or be {IGNORE_INDEX}" if task == "segmentation" else "")
            + f", found {bad}."
        )
    return t


def flatten_groups(depth_m, valid, targets, variants: bool = True):
    """Images and targets for training from labeled groups.

    Args:
        depth_m, valid: (n, G, H, W) groups, observed image first.
        targets: (n,) labels or (n, H, W) masks, one per group.
        variants: train on all G images of a group (each with the group's label or
            mask), else on the observed image only.

    Returns:
        depth_m, valid: (n * G, H, W) (or (n, H, W)), group-major; targets repeated to match.
    """
    depth_m, valid, targets = np.asarray(depth_m), np.asarray(valid), np.asarray(targets)
    if depth_m.ndim != 4 or valid.shape != depth_m.shape or len(targets) != len(depth_m):
        raise ValueError(
            f"expected (n, G, H, W) depth_m and valid and n targets, got {depth_m.shape}, "
            f"{valid.shape} and {targets.shape}."
        )
    g = depth_m.shape[1] if variants else 1
    shape = depth_m.shape[2:]
    return (
        depth_m[:, :g].reshape(-1, *shape),
        valid[:, :g].reshape(-1, *shape),
        np.repeat(targets, g, axis=0),
    )


def random_shift(
    x: torch.Tensor, y: torch.Tensor | None, max_px: tuple[int, int], gen: torch.Generator
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Translate each image of a batch by its own random integer offset.

    Args:
        x: (B, C, H, W) network input (normalised depth, validity); what shifts in is
            zeros, i.e. voids.
        y: (B, H, W) masks (shifted alike, IGNORE_INDEX shifted in) or None.
        max_px: (rows, cols) largest offset; offsets are uniform on [-max, max].
        gen: CPU generator of the offsets (reproducible on any device).
    """
    sy, sx = max_px
    b, _, h, w = x.shape
    dy = torch.randint(-sy, sy + 1, (b,), generator=gen).tolist()
    dx = torch.randint(-sx, sx + 1, (b,), generator=gen).tolist()
    # one strided block copy per image: 2-4x faster on the CPU than one gather over the
    # batch, and the same pixels (out[r, c] = x[r - dy, c - dx], voids shifted in)
    out = torch.zeros_like(x)
    y_out = None if y is None else torch.full_like(y, IGNORE_INDEX)
    for i, (oy, ox) in enumerate(zip(dy, dx, strict=True)):
        r0, r1, c0, c1 = max(oy, 0), h + min(oy, 0), max(ox, 0), w + min(ox, 0)
        if r1 <= r0 or c1 <= c0:  # shifted out of the frame entirely
            continue
        out[i, :, r0:r1, c0:c1] = x[i, :, r0 - oy : r1 - oy, c0 - ox : c1 - ox]
        if y is not None:
            y_out[i, r0:r1, c0:c1] = y[i, r0 - oy : r1 - oy, c0 - ox : c1 - ox]
    return out, y_out


def random_crop_columns(
    x: torch.Tensor, y: torch.Tensor | None, width_px: int, gen: torch.Generator
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Keep a random window of ``width_px`` columns of each image of a batch.

    Args:
        x: (B, C, H, W) network input.
        y: (B, H, W) masks (cropped alike) or None.
        width_px: W' <= W, the window width; offsets are uniform on [0, W - W'].
        gen: CPU generator of the offsets.

    Returns:
        x (B, C, H, W') and y (B, H, W') or None.
    """
    b, _, _, w = x.shape
    start = torch.randint(0, w - width_px + 1, (b,), generator=gen).to(x.device)
    cols = start[:, None] + torch.arange(width_px, device=x.device)[None]  # (B, W')
    x = torch.take_along_dim(x, cols[:, None, None, :].expand(-1, x.shape[1], x.shape[2], -1), 3)
    if y is not None:
        y = torch.take_along_dim(y, cols[:, None, :].expand(-1, y.shape[1], -1), 2)
    return x, y


def random_affine(
    x: torch.Tensor,
    y: torch.Tensor | None,
    *,
    rotate_deg: float,
    scale: float,
    gen: torch.Generator,
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Rotate and zoom each image of a batch about its centre by its own random amount.

    Output pixel p takes the input pixel at ``centre + R(-a) (p - centre) / z`` (nearest
    sampling, so a depth is moved, never averaged with a neighbour), with the angle
    a ~ U(-rotate_deg, rotate_deg) and the zoom z ~ U(1 - scale, 1 + scale); angles
    are in pixel space, so a non-square image is rotated without shearing.

    Args:
        x: (B, C, H, W) network input; what comes in from outside the frame is zeros
            (voids).
        y: (B, H, W) masks (transformed alike, IGNORE_INDEX outside) or None.
        gen: CPU generator of the angles and zooms.
    """
    b, _, h, w = x.shape
    angle = torch.deg2rad((2 * torch.rand(b, generator=gen) - 1) * rotate_deg)
    zoom = 1 + (2 * torch.rand(b, generator=gen) - 1) * scale
    cos, sin = torch.cos(angle) / zoom, torch.sin(angle) / zoom
    # Pixel-space matrix in affine_grid's normalised coordinates: D A D^-1, D = diag(2/W, 2/H).
    theta = torch.zeros(b, 2, 3)
    theta[:, 0, 0], theta[:, 0, 1] = cos, -sin * h / w
    theta[:, 1, 0], theta[:, 1, 1] = sin * w / h, cos
    grid = F.affine_grid(theta.to(x.device, x.dtype), list(x.shape), align_corners=False)
    x = F.grid_sample(x, grid, mode="nearest", padding_mode="zeros", align_corners=False)
    if y is not None:
        # Shift labels by one so that zero padding marks the outside, then map it to ignore.
        moved = (
            F.grid_sample((y.to(x.dtype) + 1)[:, None], grid, mode="nearest", align_corners=False)[
                :, 0
            ]
            .round()
            .long()
            - 1
        )
        y = torch.where(moved < 0, IGNORE_INDEX, moved)
    return x, y


def soft_cross_entropy(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Mean over the batch of -sum_c q(c) log softmax(logits)(c), q: (B, C) target rows."""
    return -(target * F.log_softmax(logits.float(), dim=1)).sum(dim=1).mean()


class ProgressLog:
    """Writes progress lines to stderr (None), an open text stream, or a file path (appended)."""

    def __init__(self, log: str | os.PathLike | TextIO | None) -> None:
        self._own = False
        if log is None:
            self.stream = sys.stderr
        elif hasattr(log, "write"):
            self.stream = log
        else:
            self.stream = open(log, "a", encoding="utf-8")  # noqa: SIM115 - closed in close()
            self._own = True

    def line(self, text: str) -> None:
        """Write one line and flush it (a job log is read while the job runs)."""
        self.stream.write(text + "\n")
        self.stream.flush()

    def close(self) -> None:
        """Close the file when this log opened it."""
        if self._own:
            self.stream.close()


def _soft_targets(
    x: torch.Tensor,
    y: torch.Tensor,
    n_classes: int,
    cfg: TrainConfig,
    rng: np.random.Generator | None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Mixup and label smoothing of a classification batch: images (B, C, H, W) and
    target rows q (B, n_classes), q = (1 - eps) [lam e_y + (1 - lam) e_y'] + eps / n_classes.
    ``rng`` draws lam and the partners y' (unused, may be None, without mixup)."""
    q = F.one_hot(y, n_classes).to(x.dtype)
    if cfg.mixup > 0:
        lam = torch.from_numpy(rng.beta(cfg.mixup, cfg.mixup, size=len(y))).to(x.device, x.dtype)
        partner = torch.from_numpy(rng.permutation(len(y))).to(x.device)
        x = lam.view(-1, 1, 1, 1) * x + (1 - lam.view(-1, 1, 1, 1)) * x[partner]
        q = lam[:, None] * q + (1 - lam[:, None]) * q[partner]
    eps = cfg.label_smoothing
    return x, (1 - eps) * q + eps / n_classes


def train(
    model: nn.Module,
    depth_m,
    valid,
    targets,
    *,
    cfg: TrainConfig | dict | None = None,
    seed: int = 0,
    compute: Compute | None = None,
    log: str | os.PathLike | TextIO | None = None,
    groups: int | None = None,
) -> nn.Module:
    """Train ``model`` on images and their labels (or masks); returns the model.

    Mini-batch SGD with momentum and weight decay, a cosine learning-rate schedule
    per step, optional horizontal flips and random shifts, masked cross-entropy
    (segmentation ignores IGNORE_INDEX and every invalid pixel) over the units
    ``spl_al.models.training_outputs`` names (every pixel, or PointNet++'s sampled
    points). With
    ``cfg.from_scratch`` the weights are first re-initialised from ``seed``; batch
    order, flips and shifts come from a CPU
    ``torch.Generator`` seeded with ``seed`` and dropout from the global RNG seeded from
    it, so the same seed, data, device and thread
    count give the same weights bit for bit. The whole set lives on the device as one
    tensor and batches are index lookups (no DataLoader overhead).

    Args:
        model: from ``spl_al.models.build_model`` (its ``task`` attribute is used).
        depth_m: (n, H, W) depth in metres, NaN at voids. A group's variants are simply
            more images here, each repeating its group's label or mask.
        valid: (n, H, W) bool validity (pixels also need a finite depth).
        targets: (n,) int class indices, or (n, H, W) uint8 masks (IGNORE_INDEX = ignore).
        cfg: a ``TrainConfig`` (or a dict for ``TrainConfig.from_dict``).
        seed: seed of initialisation, batch order and augmentation.
        compute: where and at which precision it trains (``Compute``; resolved for
            the model unless it is already; None: ``LOCAL``). Its threads are the
            caller's to apply (``Compute.apply``), once per process.
        log: where progress lines go: None = stderr, a path (appended) or a stream.
        groups: how many labeled groups the images come from (for
            ``cfg.steps_per_group`` and, with ``cfg.steps_by`` "groups", the steps of
            an epoch; None: each image is its own group). The number of steps is
            ``cfg.total_steps(n, groups)``, each of ``cfg.batch_images(n)`` images.
    """
    cfg = cfg if isinstance(cfg, TrainConfig) else TrainConfig.from_dict(cfg)
    depth_m = np.asarray(depth_m)
    t = _check_inputs(model, depth_m, targets, cfg, groups)
    compute = (compute or LOCAL).resolved(model)
    dev, precision = compute.torch_device, compute.precision
    x_all, y_all = _training_set(model, depth_m, valid, t, dev)
    class_weight = (
        balanced_class_weights(y_all, model.n_classes, cfg.balance).to(dev)
        if cfg.balance > 0
        else None
    )
    if cfg.from_scratch:
        reset_parameters(model, seed)
    else:  # fine-tuning: the weights stay, the model's own draws follow the seed
        seed_own_draws(model, seed)
    model.to(dev)
    if cfg.channels_last:
        model.to(memory_format=torch.channels_last)
    schedule = _Schedule.of(cfg, len(depth_m), groups)
    augment = _Augment(cfg, model, depth_m.shape[1:], seed)
    opt = SGD(
        model.parameters(),
        lr=cfg.lr,
        momentum=cfg.momentum,
        nesterov=cfg.nesterov and cfg.momentum > 0,
        weight_decay=cfg.weight_decay,
    )
    progress = ProgressLog(log)
    progress.line(
        f"train {model.task} {getattr(model, 'arch', type(model).__name__)} on {len(depth_m)} "
        f"images {tuple(depth_m.shape[1:])}, {schedule.total} steps ({schedule.n_epochs} "
        f"epochs x {schedule.per_epoch}), batch {schedule.batch}, device {dev}, "
        f"precision {precision}, seed {seed}"
    )
    step_fn = _Step(model, opt, LossScaler(precision, dev), precision, dev, class_weight)
    model.train()
    try:
        with _seeded_global_rng(seed, dev), deterministic_algorithms():
            _run_schedule(schedule, augment, step_fn, (x_all, y_all), progress, cfg.log_every)
    finally:
        progress.close()
    model.eval()
    if cfg.channels_last:
        model.to(memory_format=torch.contiguous_format)
    return model


def _run_schedule(schedule, augment, step_fn, data, progress, log_every: int) -> None:
    """Every step of ``schedule``: each epoch a fresh permutation of the images, batches
    from ``augment``, one ``step_fn`` per batch at the schedule's learning rate; a
    progress line every ``log_every`` epochs (and the first and last)."""
    x_all, y_all = data
    opt = step_fn.opt
    start = time.perf_counter()
    step = 0
    for epoch in range(1, schedule.n_epochs + 1):
        perm = augment.permutation(len(x_all))
        stats = _EpochStats(step_fn.dev)
        for b in range(schedule.per_epoch):
            if step >= schedule.total:
                break
            lr = schedule.lr(step)
            opt.param_groups[0]["lr"] = lr
            idx = perm[b * schedule.batch : (b + 1) * schedule.batch]
            xb, yb, soft = augment.batch(x_all, y_all, idx)
            stats.add(*step_fn(xb, yb, soft))
            step += 1
        last = epoch == schedule.n_epochs
        if log_every and (epoch % log_every == 0 or epoch == 1 or last):
            elapsed = time.perf_counter() - start
            progress.line(
                f"epoch {epoch}/{schedule.n_epochs} step {step}/{schedule.total} "
                f"{stats.text()} lr {lr:.4g} {elapsed:.1f}s "
                f"({step * schedule.batch / max(elapsed, 1e-9):.0f} img/s)"
            )
    progress.line(f"done in {time.perf_counter() - start:.1f}s")


def _check_inputs(model, depth_m: np.ndarray, targets, cfg: TrainConfig, groups) -> np.ndarray:
    """Refuse a model, images, targets or groups ``train`` cannot use; the int64 targets."""
    task = getattr(model, "task", None)
    if task not in TASKS:
        raise ValueError(
            "model must come from spl_al.models.build_model (it has no task attribute)."
        )
    if depth_m.ndim != 3 or depth_m.shape[0] == 0:
        raise ValueError(f"depth_m must have shape (n, H, W) with n >= 1, got {depth_m.shape}.")
    n = depth_m.shape[0]
    t = check_targets(
        task, targets, n_images=n, image_shape=depth_m.shape[1:], n_classes=model.n_classes
    )
    if cfg.crop_width < 1 and getattr(model, "needs_grid", False):
        raise ValueError(
            f"crop_width {cfg.crop_width} needs a model that takes any image width; "
            f"{type(model).__name__} is tied to its scan grid: use crop_width 1."
        )
    if groups is not None and not 1 <= int(groups) <= n:
        raise ValueError(f"groups must lie in [1, {n}] (the images), got {groups}.")
    return t


def _training_set(model, depth_m, valid, targets: np.ndarray, dev) -> tuple:
    """The whole training set on the device: network inputs (n, C, H, W) and targets
    (n,) or (n, H, W), voids of a mask set to IGNORE_INDEX (they carry no label)."""
    x_all = model_input(model, depth_m, valid)
    y_all = torch.from_numpy(targets)
    if model.task == "segmentation":
        y_all = torch.where(x_all[:, 1] > 0, y_all, IGNORE_INDEX)
    return x_all.to(dev), y_all.to(dev)


@dataclass(frozen=True)
class _Schedule:
    """Batch size, steps and the learning rate of each step (cosine from lr to 0)."""

    batch: int
    per_epoch: int
    total: int
    n_epochs: int
    lr0: float
    cosine: bool

    @classmethod
    def of(cls, cfg: TrainConfig, n: int, groups) -> _Schedule:
        batch = cfg.batch_images(n)
        # Epochs here are passes over the images: drop the ragged last batch, the next
        # permutation covers it (so every batch is full: TrainConfig.images_seen).
        per_epoch = max(1, n // batch)
        total = cfg.total_steps(n, groups)
        return cls(batch, per_epoch, total, math.ceil(total / per_epoch), cfg.lr, cfg.cosine)

    def lr(self, step: int) -> float:
        """lr0 * (1 + cos(pi step / total)) / 2 (cosine), else lr0."""
        return self.lr0 * (0.5 * (1 + math.cos(math.pi * step / self.total)) if self.cosine else 1)


class _Augment:
    """Batch order and augmentation of one training run, all drawn from its seed: a CPU
    ``torch.Generator`` for permutations, flips, shifts, rotations and crops, a numpy
    generator for mixup."""

    def __init__(self, cfg: TrainConfig, model, image_shape, seed: int) -> None:
        self.cfg = cfg
        self.task = model.task
        self.n_classes = model.n_classes
        self.width = image_shape[1]
        self.shift_px = tuple(round(cfg.shift * s) for s in image_shape)
        self.crop_px = max(1, round(cfg.crop_width * image_shape[1]))
        self.gen = torch.Generator().manual_seed(int(seed))
        self.mix_rng = np.random.default_rng([int(seed), 3])

    def permutation(self, n: int) -> torch.Tensor:
        """The order of one epoch's images."""
        return torch.randperm(n, generator=self.gen)

    def batch(self, x_all, y_all, idx):
        """Images (B, C, H, W'), hard targets and, for mixup or label smoothing, the soft
        target rows (B, C) (else None) of the images ``idx``, augmented."""
        cfg, seg = self.cfg, self.task == "segmentation"
        flip = (torch.rand(len(idx), generator=self.gen) < 0.5) if cfg.hflip else None
        idx = idx.to(x_all.device)
        xb, yb = x_all[idx], y_all[idx]
        if flip is not None:
            flip = flip.to(x_all.device)
            xb = torch.where(flip.view(-1, 1, 1, 1), xb.flip(-1), xb)
            if seg:
                yb = torch.where(flip.view(-1, 1, 1), yb.flip(-1), yb)
        masks = yb if seg else None
        if max(self.shift_px) > 0:
            xb, masks = random_shift(xb, masks, self.shift_px, self.gen)
        if cfg.rotate_deg > 0 or cfg.scale > 0:
            xb, masks = random_affine(
                xb, masks, rotate_deg=cfg.rotate_deg, scale=cfg.scale, gen=self.gen
            )
        if self.crop_px < self.width:
            xb, masks = random_crop_columns(xb, masks, self.crop_px, self.gen)
        if seg:
            yb = masks
        soft = None
        if not seg and (cfg.mixup > 0 or cfg.label_smoothing > 0):
            xb, soft = _soft_targets(xb, yb, self.n_classes, cfg, self.mix_rng)
        if cfg.channels_last:
            xb = xb.contiguous(memory_format=torch.channels_last)
        return xb, yb, soft


class _Step:
    """One SGD step: forward under the precision's autocast, the loss in fp32 (masked
    cross-entropy of hard targets, or soft cross-entropy), backward, update."""

    def __init__(self, model, opt, scaler, precision, dev, class_weight) -> None:
        self.model, self.opt, self.scaler = model, opt, scaler
        self.precision, self.dev, self.class_weight = precision, dev, class_weight

    def __call__(self, xb, yb, soft):
        """Returns (logits, the targets they are scored against, loss)."""
        with autocast(self.precision, self.dev):
            if soft is None:
                logits, yb = training_outputs(self.model, xb, yb)
            else:
                logits, _ = self.model(xb)
        if soft is None:
            loss = masked_cross_entropy(logits, yb, self.class_weight)
        else:
            loss = soft_cross_entropy(logits, soft)
        self.opt.zero_grad(set_to_none=True)
        self.scaler.backward(loss)
        self.scaler.step(self.opt)
        return logits, yb, loss


class _EpochStats:
    """Running loss and accuracy of an epoch over its counted units, on the device."""

    def __init__(self, dev) -> None:
        self.loss_sum = torch.zeros((), device=dev)
        self.hits = torch.zeros((), device=dev)
        self.units = torch.zeros((), device=dev)

    def add(self, logits, yb, loss) -> None:
        """Count one step's units (targets not IGNORE_INDEX)."""
        with torch.no_grad():
            kept = yb != IGNORE_INDEX
            n_kept = kept.sum()
            self.loss_sum += loss.detach() * n_kept
            self.hits += ((logits.argmax(1) == yb) & kept).sum()
            self.units += n_kept

    def text(self) -> str:
        """The epoch's mean loss and training accuracy so far, as log text."""
        u = max(float(self.units), 1.0)
        return f"loss {float(self.loss_sum) / u:.4f} train_acc {float(self.hits) / u:.3f}"


@contextlib.contextmanager
def _seeded_global_rng(seed: int, dev):
    """Dropout draws from torch's global RNG, whose start seed differs per process: seed
    it from ``seed`` inside a fork, so the caller's stream is left as it was."""
    forked = (
        [dev.index if dev.index is not None else torch.cuda.current_device()]
        if dev.type == "cuda"
        else []
    )
    with torch.random.fork_rng(devices=forked):
        torch.manual_seed(int(np.random.SeedSequence([int(seed), 1]).generate_state(1)[0]))
        yield

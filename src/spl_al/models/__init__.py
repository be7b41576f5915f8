"""Networks for SPL depth images; each returns ``(logits, features)`` from one pass.

Public API:

- ``build_model(task, n_classes, arch=None, seed=None, **arch_params)``: a model for
  "classification" (logits (B, C), features (B, d)) or "segmentation" (logits
  (B, C, H, W), features (B, d, H, W)); its ``task``, ``n_classes`` and
  ``feature_dim`` attributes say what it is.
- ``to_input(depth_m, valid)``: the (B, 2, H, W) input (normalised depth, validity).
- ``model_input(model, depth_m, valid)``: the input ``model`` takes, by its
  ``input_kind``: "normalised" (``to_input``, every image network) or "range_m"
  (``to_range_input``: range in metres and validity, for PointNet++). Training,
  prediction and scoring all build their input with it.
- ``needs_grid(task, arch)``: whether the architecture is built with the scan grid
  of the images (``grid=dataset.grid()``; PointNet++ turns pixels into points with it).
- ``training_outputs(model, x, target)``: the logits and targets a training step
  scores (every unit, or the model's own choice: PointNet++ its sampled points).
- ``reset_parameters(model, seed)``: deterministic re-initialisation.
- ``seed_own_draws(model, seed)``: the model's own training draws (PointNet++'s point
  sampler) seeded, weights kept: what a fine-tuning does instead of re-initialising.
- ``ARCHS``: the architectures per task (the first one is the task's default), filled
  by ``register(task, name, default=False)`` on each model class (``models.registry``).
"""

from __future__ import annotations

import torch
from torch import nn

# (importing a model module registers its classes: models.registry)
from spl_al.models.classifier import ResNet, SmallCNN
from spl_al.models.normalise import to_input, to_range_input
from spl_al.models.pointnet import PointNet2Seg
from spl_al.models.registry import ARCHS, TASKS, register
from spl_al.models.segmenter import UNet

INPUT_KINDS = {"normalised": to_input, "range_m": to_range_input}


def model_input(model: nn.Module, depth_m, valid=None) -> torch.Tensor:
    """The (B, 2, H, W) input ``model`` takes for (B, H, W) depth images (NaN at voids).

    By the model's ``input_kind`` attribute (default "normalised"): ``to_input``
    (robustly standardised depth, validity) or ``to_range_input`` (range in metres,
    validity).
    """
    kind = getattr(model, "input_kind", "normalised")
    if kind not in INPUT_KINDS:
        raise ValueError(f"model input_kind must be one of {sorted(INPUT_KINDS)}, got {kind!r}.")
    return INPUT_KINDS[kind](depth_m, valid)


def training_outputs(
    model: nn.Module, x: torch.Tensor, target: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """The (logits, target) pair a training step scores for input ``x`` and ``target``.

    By default every unit: ``model(x)[0]`` with ``target`` unchanged ((B, C) / (B,) or
    (B, C, H, W) / (B, H, W)). A model with a ``training_outputs(x, target)`` method
    decides itself (PointNet++ scores its sampled points: (B, C, N) / (B, N)).
    """
    own = getattr(model, "training_outputs", None)
    if own is not None:
        return own(x, target)
    return model(x)[0], target


def needs_grid(task: str, arch: str | None) -> bool:
    """Whether ``build_model(task, ..., arch)`` needs ``grid=`` (the images' scan grid)."""
    archs = ARCHS.get(task, {})
    cls = archs.get(next(iter(archs)) if arch is None and archs else arch)
    return bool(getattr(cls, "needs_grid", False))


def model_class(task: str, arch: str | None) -> type:
    """The class ``build_model(task, ..., arch)`` builds (None: the task's default)."""
    archs = ARCHS.get(task, {})
    name = next(iter(archs)) if arch is None and archs else arch
    if name not in archs:
        raise ValueError(f"arch for task {task!r} must be one of {sorted(archs)}, got {arch!r}.")
    return archs[name]


def reset_parameters(model: nn.Module, seed: int) -> None:
    """Re-initialise ``model`` in place from ``seed``, identically on every device.

    The weights are drawn on the CPU (under a forked global RNG, which is left as it
    was) and moved back to the model's device, so CPU and CUDA runs start equal.
    """
    if not hasattr(model, "init_weights"):
        raise ValueError(
            f"model {type(model).__name__} has no init_weights(); build it with build_model."
        )
    param = next(model.parameters(), None)
    device = param.device if param is not None else torch.device("cpu")
    model.cpu()
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(int(seed))
        model.init_weights()
    model.to(device)


def seed_own_draws(model: nn.Module, seed: int) -> None:
    """Seed the draws ``model`` makes itself in training (PointNet++'s point sampler)
    from ``seed``, weights kept; models that draw nothing are left as they are."""
    if hasattr(model, "seed_sampler"):
        model.seed_sampler(seed)


def build_model(
    task: str, n_classes: int, arch: str | None = None, seed: int | None = None, **arch_params
) -> nn.Module:
    """Build a network for ``task`` with ``n_classes`` outputs.

    Args:
        task: "classification" or "segmentation".
        n_classes: number of classes C (>= 2).
        arch: a name in ``ARCHS[task]``; None picks the task's default
            ("smallcnn" for classification, "unet" for segmentation; "pointnet2"
            is PointNet++ on the images' points and needs ``grid``).
        seed: if given, the weights are initialised from it (``reset_parameters``) and
            the global torch RNG is left untouched; otherwise torch's global RNG is used.
        **arch_params: keyword arguments of the architecture (e.g. width, stem, depth).

    Returns:
        an ``nn.Module`` whose ``forward(x)`` maps (B, 2, H, W) to (logits, features).
    """
    if task not in ARCHS:
        raise ValueError(f"task must be one of {TASKS}, got {task!r}.")
    if int(n_classes) != n_classes or n_classes < 2:
        raise ValueError(f"n_classes must be an integer >= 2, got {n_classes!r}.")
    archs = ARCHS[task]
    name = next(iter(archs)) if arch is None else arch
    if name not in archs:
        raise ValueError(f"arch for task {task!r} must be one of {sorted(archs)}, got {arch!r}.")
    # with a seed, construction must not consume the global RNG either
    with torch.random.fork_rng(devices=[], enabled=seed is not None):
        try:
            model = archs[name](int(n_classes), **arch_params)
        except TypeError as exc:
            raise ValueError(f"bad arch_params for {name!r}: {exc}.") from None
    model.arch = name
    if seed is not None:
        reset_parameters(model, seed)
    return model


__all__ = [
    "ARCHS",
    "INPUT_KINDS",
    "TASKS",
    "PointNet2Seg",
    "ResNet",
    "SmallCNN",
    "UNet",
    "build_model",
    "model_class",
    "model_input",
    "needs_grid",
    "register",
    "reset_parameters",
    "seed_own_draws",
    "to_input",
    "to_range_input",
    "training_outputs",
]

"""A dataset's configured model: built from its config, loaded from and saved to its
weights file. Every step and bench that needs one imports it from here."""

from __future__ import annotations

import torch

from spl_al.atomic import atomic_write
from spl_al.models import build_model, model_class, needs_grid


def model_for(dataset, model_cfg: dict):
    """The configured model (``model_cfg``: arch and its parameters) for ``dataset``;
    an architecture that needs the scan grid (PointNet++) gets ``dataset.grid()``."""
    cfg = dict(model_cfg)
    arch = cfg.pop("arch", None)
    if needs_grid(dataset.task, arch):
        cfg["grid"] = dataset.grid()
    return build_model(dataset.task, len(dataset.classes), arch=arch, **cfg)


def resolved_for(compute, dataset, model_cfg: dict):
    """``compute`` (a ``training.compute.Compute``) resolved for ``dataset``'s configured
    model (``Compute.resolved``): where a step decides, once, the device and what
    precision "auto" means there, before it builds or loads the model."""
    return compute.resolved(model_class(dataset.task, model_cfg.get("arch")))


def load_model(dataset, model_cfg: dict, weights):
    """``model_for`` with the saved ``weights`` loaded, in eval mode."""
    model = model_for(dataset, model_cfg)
    model.load_state_dict(torch.load(weights, map_location="cpu", weights_only=True))
    return model.eval()


def save_model(model, path) -> None:
    """Save the model's weights (state dict) atomically, the same weights to the same bytes.

    torch.save names the archive's inner folder after a path it is given, which here
    would be the random temporary name: saving through a file object keeps it fixed,
    so a model card's sha256 identifies the weights across reruns.
    """
    state = model.state_dict()

    def write(tmp):
        with open(tmp, "wb") as f:
            torch.save(state, f)

    atomic_write(path, write)

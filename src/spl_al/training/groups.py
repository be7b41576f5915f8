"""Training a model on labeled sample groups, as an active-learning round trains it."""

from __future__ import annotations

import numpy as np

from spl_al.training.fit import train
from spl_al.training.recipe import TrainConfig


def train_groups(
    dataset,
    samples,
    *,
    given,
    model,
    fit: dict,
    n_variants: int,
    seed: int,
    compute=None,
    log=None,
):
    """Train ``model`` on the groups of dataset samples ``samples`` as a round trains:
    each group's observed image and first ``n_variants`` variants, all with the group's
    label or mask (``given``, one per sample). ``fit``: TrainConfig fields;
    ``compute``: where and at which precision (``Compute``, as ``train`` takes it).
    Returns (the model, its TrainConfig, the number of training images)."""
    cfg = TrainConfig.from_dict(fit)
    depth, valid = dataset.groups(samples, n_variants=n_variants)
    targets = np.repeat(given, depth.shape[1], axis=0)
    images = depth.reshape(-1, *depth.shape[2:])
    model = train(
        model,
        images,
        valid.reshape(images.shape),
        targets,
        cfg=cfg,
        seed=seed,
        compute=compute,
        log=log,
        groups=len(samples),
    )
    return model, cfg, int(images.shape[0])

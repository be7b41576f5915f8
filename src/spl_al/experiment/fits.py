"""A round's model: trained on its labeled groups and evaluated on the test split
(``fit_and_evaluate``), or taken from round 0's shared fit record (``fit_of_record``),
and what a round's metrics record keeps of it (``fit_facts``, ``dataset_facts``).
Torch is imported inside the functions that train.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from spl_al.seeding import TRAIN, round_seed
from spl_al.training.compute import Compute


@dataclass
class Fit:
    """A trained model and what its round records of it."""

    model: object
    metrics: dict
    train_images: int
    train_seconds: float
    precision: str
    train_steps: int | None = None  # optimiser steps (None: a fit record that predates them)
    images_seen: int | None = None  # images drawn over those steps

    def steps(self) -> dict:
        """``train_steps`` and ``images_seen`` for a record (none when unknown)."""
        return {
            k: int(v)
            for k, v in (("train_steps", self.train_steps), ("images_seen", self.images_seen))
            if v is not None
        }


def fit_and_evaluate(
    dataset,
    pool_idx,
    *,
    given,
    train_setup: dict,
    n_variants,
    seed,
    round_,
    compute: Compute,
    log,
    warm_from=None,
) -> Fit:
    """Train a model on the labeled groups ``pool_idx`` (their labels or masks
    ``given``; ``n_variants`` variants each) and evaluate it on the test split.

    ``train_setup``: ``model`` (arch and parameters) and ``fit`` (a TrainConfig).
    ``compute``: resolved (``Compute.resolved``); its precision is the fit's, the one
    the ``Fit`` records (the evaluation runs at ``MEASURE_PRECISION``, fp32).
    ``warm_from``: the weights of the method's previous round; when given, training
    starts from them with ``fit`` updated by ``train_setup["warm_start"]`` (fewer
    steps), else from fresh weights.
    """
    # torch on demand (importing this module does not load it)
    from spl_al.models.configured import load_model, model_for
    from spl_al.training import evaluate
    from spl_al.training.groups import train_groups

    started = time.perf_counter()
    model = (
        model_for(dataset, train_setup["model"])
        if warm_from is None
        else load_model(dataset, train_setup["model"], warm_from).train()
    )
    fit = train_setup.get("fit", {})
    if warm_from is not None:
        fit = {**fit, **(train_setup.get("warm_start") or {}), "from_scratch": False}
    model, cfg, n = train_groups(
        dataset,
        dataset.train_idx[pool_idx],
        given=given,
        model=model,
        fit=fit,
        n_variants=n_variants,
        seed=round_seed(TRAIN, seed, round_),
        compute=compute,
        log=log,
    )
    train_seconds = time.perf_counter() - started
    test = dataset.test_idx
    metrics = evaluate(
        model,
        dataset.depth_m[test],
        dataset.valid[test],
        dataset.labels[test],
        levels=dataset.level[test],
        classes=dataset.classes,
        compute=compute.measuring(),  # (not the training's precision: see the docstring)
        batch_size=cfg.eval_batch_size,
    )
    groups = len(pool_idx)
    return Fit(
        model,
        metrics,
        n,
        train_seconds,
        compute.precision,
        train_steps=cfg.total_steps(n, groups),
        images_seen=cfg.images_seen(n, groups),
    )


def fit_of_record(model, record: dict) -> Fit:
    """A ``Fit`` of ``train_initial``'s record (``model``: its weights loaded, or None)."""
    return Fit(
        model,
        record["metrics"],
        record["train_images"],
        record["train_seconds"],
        record["precision"],
        train_steps=record.get("train_steps"),
        images_seen=record.get("images_seen"),
    )


def dataset_facts(dataset) -> dict:
    """What a metrics record needs of a dataset, for steps that do not load it."""
    return {
        "task": dataset.task,
        "n_samples": len(dataset),
        "n_train": len(dataset.train_idx),
        "n_variants": int(dataset.n_variants),
        "synthetic_standin": bool(dataset.meta.get("synthetic_standin", False)),
    }


def fit_facts(fit: Fit, *, score_seconds: float, started: float) -> dict:
    """What a round's metrics record holds of its fit: training images, optimiser steps
    and images seen, seconds (training, scoring, the whole step) and precision."""
    return {
        "train_images": fit.train_images,
        **fit.steps(),
        "train_seconds": round(fit.train_seconds, 3),
        "score_seconds": score_seconds,
        "seconds": round(time.perf_counter() - started, 3),
        "precision": fit.precision,
    }

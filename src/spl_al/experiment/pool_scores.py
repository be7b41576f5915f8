"""Scores of the unlabeled pool: the forward passes a strategy declares it needs
(``score_pool``, one method's; ``score_every_need``, round 0's shared scores for every
strategy), on the observed images and, for the group needs, the method's variants.
No label is read; the scores are measured at ``MEASURE_PRECISION`` (fp32) whatever
trained the model. Torch is imported inside the functions that score.
"""

from __future__ import annotations

import numpy as np

from spl_al.experiment.plan import MethodSpec
from spl_al.strategies import StrategyInputs, get
from spl_al.strategies.inputs import ARRAY_FIELDS, GROUP_NEEDS, NEEDS
from spl_al.training.compute import LOCAL, Compute


def score_variants(method: MethodSpec, needs, n_variants: int) -> int:
    """Variants per group a strategy's scoring runs on: its method's M when it needs
    group predictions (DUIS), else 0 (observed images only)."""
    return method.variants_seen(n_variants) if needs & GROUP_NEEDS else 0


def score_every_need(model, dataset, *, pool_idx, m, out_path, compute) -> None:
    """Scores of the unlabeled pool for every strategy: the observed-image needs, and
    with ``m`` > 0 the group needs on M = ``m`` variants."""
    # torch on demand (importing this module does not load it)
    from spl_al.scoring import compute_inputs

    unlabeled = np.setdiff1d(np.arange(len(dataset.train_idx)), pool_idx)
    # a segmenter has no classifier head (the strategies that read one are refused there)
    no_head = {"head"} if model.task != "classification" else set()
    observed = frozenset(NEEDS) - GROUP_NEEDS - no_head
    passes = [(0, observed)] + ([(m, GROUP_NEEDS)] if m else [])
    parts = {}
    for m_scored, needs in passes:
        depth, valid = dataset.groups(dataset.train_idx, n_variants=m_scored)
        inputs = compute_inputs(
            model,
            needs,
            depth_m=depth,
            valid=valid,
            unlabeled_idx=unlabeled,
            labeled_idx=pool_idx,
            compute=compute.measuring(),
        )
        parts.update(
            {f: getattr(inputs, f) for f in ARRAY_FIELDS if getattr(inputs, f) is not None}
        )
    StrategyInputs(unlabeled_idx=unlabeled, labeled_idx=pool_idx, **parts).save(out_path)


def score_pool(
    model,
    dataset,
    *,
    labeled: np.ndarray,
    method: MethodSpec,
    compute: Compute = LOCAL,
) -> StrategyInputs:
    """Forward passes over the unlabeled training groups: exactly what the method's
    strategy needs (``strategy.needs``), for the query step, on ``compute``'s device at
    ``MEASURE_PRECISION`` (fp32), whatever precision trained the model. No labels are
    read: the strategy inputs are built from images and the model alone."""
    # torch on demand (importing this module does not load it)
    from spl_al.scoring import compute_inputs

    # What to compute depends on the strategy alone, not on its parameters.
    strategy = get(method.strategy, **method.params)
    unlabeled = np.setdiff1d(np.arange(len(dataset.train_idx)), labeled)
    m = score_variants(method, strategy.needs, dataset.n_variants)
    depth, valid = dataset.groups(dataset.train_idx, n_variants=m)
    return compute_inputs(
        model,
        strategy.needs,
        depth_m=depth,
        valid=valid,
        unlabeled_idx=unlabeled,
        labeled_idx=labeled,
        compute=compute.measuring(),
    )

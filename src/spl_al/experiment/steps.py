"""One function per workflow rule, by stage: every step reads its inputs from disk,
calls the library and writes its outputs, so it runs from a notebook or another
scheduler as well as from the Snakemake scripts in workflow/scripts.

- ``spl_al.experiment.data_steps``: ``make_dataset``, ``make_variant_shard``,
  ``merge_variants``, ``data_pictures``;
- ``spl_al.experiment.round_steps``: ``initial_set``, ``train_initial``,
  ``train_round``, ``score_round``, ``query_round`` (and ``Compute``, ``RoundId``,
  ``ModelFiles``, the small records they take);
- ``spl_al.experiment.report_steps``: ``make_table``, ``make_curves``,
  ``make_summary``, ``make_stats``.

This module gathers them under one name.
"""

from spl_al.experiment.data_steps import (
    data_pictures,
    make_dataset,
    make_variant_shard,
    merge_variants,
)
from spl_al.experiment.report_steps import make_curves, make_stats, make_summary, make_table
from spl_al.experiment.round_steps import (
    Compute,
    ModelFiles,
    RoundId,
    initial_set,
    model_for,
    query_round,
    read_labeled,
    score_pool,
    score_round,
    step_seed,
    train_initial,
    train_round,
    write_initial_set,
)

__all__ = [
    "Compute",
    "ModelFiles",
    "RoundId",
    "data_pictures",
    "initial_set",
    "make_curves",
    "make_dataset",
    "make_stats",
    "make_summary",
    "make_table",
    "make_variant_shard",
    "merge_variants",
    "model_for",
    "query_round",
    "read_labeled",
    "score_pool",
    "score_round",
    "step_seed",
    "train_initial",
    "train_round",
    "write_initial_set",
]

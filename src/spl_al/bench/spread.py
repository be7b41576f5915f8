"""Where seed-to-seed spread comes from: ``python -m spl_al.bench spread [--only real_cls]``.

A run's seed changes two things at once: which groups are labeled first (the round-0
draw) and the training run (initialisation, batch order, augmentation). For randomly
labeled sets of a few sizes of each dataset, this trains the configured learner

- on one draw with ``--seeds`` training seeds: the spread training causes;
- on ``--seeds`` draws, each with its own training seed (what seeds of a run do): the
  whole spread;

and gives the validation set's own binomial standard error sqrt(p (1 - p) / n_val) (for
segmentation, over validation images' mIoU it is not binomial; the column is left out).
All in accuracy (mIoU) points, std over the runs (ddof 1), trained and scored at
``--precision`` (default fp32; ``--threads`` torch threads).

Validation, not test: the labeled sets come from the fit part of the training pool and
every score is on its validation part, cut by ``spl_al.bench.learnability.tuning_split``
(``--val-fraction``, default 0.2 of each class for classification; ``--val-seed``,
default 0); the test split is never read.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from spl_al.bench.learnability import (
    add_compute_arguments,
    compute_of,
    default_datasets,
    learner_score,
    recipe_overrides,
    tuning_split,
)
from spl_al.bench.timing import markdown_table
from spl_al.data.validation import VALIDATION_FRACTION, VALIDATION_SEED
from spl_al.pool import initial_labeled_set


def spread_row(
    dataset,
    size: int,
    *,
    model_cfg,
    fit_cfg,
    seeds,
    variants: bool,
    val_fraction: float = VALIDATION_FRACTION,
    val_seed: int = VALIDATION_SEED,
    compute=None,
) -> dict:
    """Validation scores of ``size`` labeled groups of the fit part of
    ``tuning_split(dataset, val_fraction, val_seed)``: one draw x training seeds,
    draws x seeds."""
    pool, held_out = tuning_split(dataset, val_fraction, val_seed)

    def score(labeled, seed):
        return learner_score(
            dataset,
            labeled,
            held_out,
            model_cfg=model_cfg,
            fit_cfg=fit_cfg,
            seed=seed,
            variants=variants,
            compute=compute,
        )

    first = pool[initial_labeled_set(len(pool), size, seeds[0])]
    train_only = [score(first, s) for s in seeds]
    draws = [train_only[0]] + [
        score(pool[initial_labeled_set(len(pool), size, s)], s) for s in seeds[1:]
    ]
    return {"n": size, "train_only": train_only, "draws": draws}


def main(argv: list[str] | None = None) -> int:
    """Measure the spread of the configured datasets; print the table; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench spread", description=__doc__)
    parser.add_argument("--config", type=Path, default=Path("config/config.yaml"))
    parser.add_argument("--only", nargs="*", default=["real_cls"])
    parser.add_argument("--sizes", type=int, nargs="*", default=[20, 80])
    parser.add_argument("--seeds", type=int, nargs="*", default=[1, 2, 3, 4, 5, 6])
    parser.add_argument("--variants", action="store_true", help="train on the variants too")
    parser.add_argument("--val-fraction", type=float, default=VALIDATION_FRACTION)
    parser.add_argument("--val-seed", type=int, default=VALIDATION_SEED)
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    add_compute_arguments(parser)
    args = parser.parse_args(argv)
    overrides = recipe_overrides(args.set)
    compute = compute_of(args)
    cache = args.cache or Path(tempfile.mkdtemp(prefix="spl-al-spread-"))
    cache.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, data, model_cfg, fit_cfg in default_datasets(args.config, args.only, cache):
        model_cfg = {**model_cfg, **overrides["model"]}
        fit_cfg = {**fit_cfg, **overrides["fit"]}
        n_val = len(tuning_split(data, args.val_fraction, args.val_seed)[1])
        for size in args.sizes:
            r = spread_row(
                data,
                size,
                model_cfg=model_cfg,
                fit_cfg=fit_cfg,
                seeds=args.seeds,
                variants=args.variants,
                val_fraction=args.val_fraction,
                val_seed=args.val_seed,
                compute=compute,
            )
            mean = float(np.mean(r["draws"]))
            binomial = (
                f"{100 * np.sqrt(mean * (1 - mean) / n_val):.1f}"
                if data.task == "classification"
                else "-"
            )
            rows.append(
                [name, str(size), f"{100 * mean:.1f}",
                 f"{100 * np.std(r['train_only'], ddof=1):.1f}",
                 f"{100 * np.std(r['draws'], ddof=1):.1f}", binomial]
            )  # fmt: skip
            print(" | ".join(rows[-1]), flush=True)
    print()
    header = ["dataset", "labeled", "mean", "sd: training only", "sd: draw + training"]
    print(markdown_table([*header, "sd: validation set (binomial)"], rows))
    print(
        f"\nvalidation accuracy (mIoU) in %; validation split: {args.val_fraction} of the "
        f"training pool, seed {args.val_seed} (labeled groups: of its fit part); seeds "
        f"{args.seeds}; variants: {args.variants}; overrides: {args.set or 'none'}"
    )
    return 0

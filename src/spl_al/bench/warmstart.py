"""Warm-start benchmark: ``python -m spl_al.bench warmstart [--only DATASET ...]``.

Does fine-tuning the previous round's model with fewer steps keep a round's accuracy?
For each dataset of the config, a random-sampling sequence of labeled sets at the
budget experiment's labeled counts (nested: each round adds to the last) is trained
two ways over the same sets:

- cold: every round from fresh weights with the dataset's recipe (``train.fit``);
- warm: round 0 as cold, every later round from the previous round's weights with the
  fit fields of ``--warm`` (default: the dataset's ``train.warm_start``, else
  ``min_steps`` at half the recipe's), as the pipeline's ``train.warm_start`` does.

It prints the validation accuracy (mIoU for segmentation) of every round, mean ± std
over seeds, with and without the variants of each labeled group, and the core seconds
one sequence took. Validation, not test: the training pool is cut by
``spl_al.data.validation_split`` as in the learnability bench, the labeled sets come
from its fit part and every score is on its validation part.
"""

from __future__ import annotations

import argparse
import io
import tempfile
import time
from pathlib import Path

import numpy as np

from spl_al.bench.learnability import default_datasets, recipe_overrides, tuning_split
from spl_al.bench.timing import markdown_table
from spl_al.data.dataset import HEADLINE_METRICS
from spl_al.training.compute import Compute

SEEDS = (1, 2, 3)
HEADER = ["dataset", "training", "start", "steps (rounds >= 1)", "core s", "accuracy by labeled"]


def budget_counts(entry: dict) -> list[int]:
    """Labeled groups at every round of the dataset's budget experiment."""
    # pandas on demand (importing this module does not load it)
    from spl_al.experiment.plan import labeled_at

    rounds = int(entry["experiments"]["budget"]["rounds"])
    return [labeled_at(entry["al"], r) for r in range(rounds)]


def sequence_scores(
    data, counts, *, model_cfg: dict, fit_cfg: dict, warm: dict | None, seed: int, variants: bool
) -> tuple[list[float], float]:
    """Validation scores (%) of one random-sampling sequence, and its seconds: every
    round trained cold, or (``warm``) rounds >= 1 fine-tuned with those fit fields."""
    # torch on demand (importing this module does not load it)
    from spl_al.models.configured import model_for
    from spl_al.training import evaluate
    from spl_al.training.groups import train_groups

    Compute(threads=1).apply()  # one thread, as a pipeline job trains (process time)
    fit_idx, val_idx = tuning_split(data)
    order = np.random.default_rng(seed).permutation(fit_idx)
    model, scores, started = None, [], time.process_time()
    for r, n in enumerate(counts):
        labeled = order[:n]
        fit = {**fit_cfg, "log_every": 0}
        if warm is not None and r > 0:
            fit = {**fit, **warm, "from_scratch": False}
        else:
            model = model_for(data, model_cfg)
        model, _cfg, _ = train_groups(
            data,
            labeled,
            given=data.labels[labeled],
            model=model.train(),
            fit=fit,
            n_variants=data.n_variants if variants else 0,
            seed=1000 * seed + r,
            log=io.StringIO(),
        )
        metrics = evaluate(model, data.depth_m[val_idx], data.valid[val_idx], data.labels[val_idx])
        scores.append(100 * float(metrics[HEADLINE_METRICS[data.task]]))
    return scores, time.process_time() - started


def _cells(values: np.ndarray) -> str:
    """'n: mean ± std' per round, values (seeds, rounds)."""
    means, stds = values.mean(0), values.std(0, ddof=1)
    return ", ".join(f"{m:.1f} ± {s:.1f}" for m, s in zip(means, stds, strict=True))


def main(argv: list[str] | None = None) -> int:
    """Print the cold and warm rounds' scores of the config's datasets as a table."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench warmstart", description=__doc__)
    parser.add_argument("--config", type=Path, default=Path("config/config.yaml"))
    parser.add_argument("--only", nargs="*", default=None, help="datasets of the config")
    parser.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS))
    parser.add_argument(
        "--warm", nargs="*", default=[], help="fit fields of a warm round, e.g. min_steps=150"
    )
    parser.add_argument(
        "--observed", action="store_true", help="also train on the observed images alone"
    )
    parser.add_argument("--cache", type=Path, default=None, help="folder for synthesised data")
    args = parser.parse_args(argv)
    import yaml

    config = yaml.safe_load(args.config.read_text())
    cache = args.cache or Path(tempfile.mkdtemp(prefix="spl_al_warmstart_"))
    cache.mkdir(parents=True, exist_ok=True)
    given = recipe_overrides([f"fit.{item}" for item in args.warm])["fit"]
    rows = []
    for name, data, model_cfg, fit_cfg in default_datasets(args.config, args.only, cache):
        entry = config["datasets"][name]
        counts = budget_counts(entry)
        warm = (
            given
            or entry["train"].get("warm_start")
            or {"min_steps": max(1, int(fit_cfg.get("min_steps", 0)) // 2)}
        )
        for variants in (True, False) if args.observed else (True,):
            for start, fields in (("cold", None), ("warm", warm)):
                runs = [
                    sequence_scores(
                        data,
                        counts,
                        model_cfg=model_cfg,
                        fit_cfg=fit_cfg,
                        warm=fields,
                        seed=s,
                        variants=variants,
                    )
                    for s in args.seeds
                ]
                scores = np.array([r[0] for r in runs])
                steps = ", ".join(f"{k}={v}" for k, v in fields.items()) if fields else "recipe"
                rows.append([
                    name, "with variants" if variants else "observed", start, steps,
                    f"{np.mean([r[1] for r in runs]):.0f}",
                    f"{'/'.join(map(str, counts))}: {_cells(scores)}",
                ])  # fmt: skip
                print(" | ".join(rows[-1]), flush=True)
    print()
    print(
        f"validation accuracy (segmentation: mIoU) in % at each round's labeled groups, "
        f"mean ± std over seeds {args.seeds}; core s: CPU seconds of one sequence"
    )
    print(markdown_table(HEADER, rows))
    return 0

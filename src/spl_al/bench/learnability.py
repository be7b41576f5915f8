"""Learnability benchmark: ``python -m spl_al.bench learnability [DATASET.npz ...]``.

How well does the learner do with few labels? For each dataset: validation accuracy
(mIoU for segmentation) of the configured model and training recipe against the number
of randomly labeled groups (about 2, 5, 10, 25 and 100% of the fit part of the training
pool), trained on the observed images only and on every image of the labeled groups
(the variants too), mean ± std over seeds, beside a linear reference on the same
labeled sets:

- classification: logistic regression on the image standardised as the network sees
  it (``spl_al.models.to_input``), bilinearly downsampled to 16x16, plus the
  downsampled validity mask (512 features);
- segmentation: per-pixel logistic regression on local depth features (range, row,
  3x3 and 7x7 mean depth offsets, 3x3 spread, gradients, local validity).

Validation, not test: this bench tunes recipes, so it never reads the test split. The
training pool is cut once per dataset by ``spl_al.data.validation_split`` (fraction
``--val-fraction``, default 0.2 of each class for classification, of the pool for
segmentation; seed ``--val-seed``, default 0); the labeled sets are drawn from the fit
part and every score is on the validation part's observed images.

Without arguments it runs the default config's datasets (synthesised as the pipeline
makes them) and SPL digits, a folder dataset nothing was tuned on
(``spl_al.data.digits``). A dataset file must carry variants (``python -m
spl_al.data variants``) for the "with variants" rows.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from spl_al.bench.timing import markdown_table
from spl_al.data import Dataset, load_folder
from spl_al.data.dataset import HEADLINE_METRICS
from spl_al.data.digits import write_digits_folder
from spl_al.data.validation import VALIDATION_FRACTION, VALIDATION_SEED, validation_split
from spl_al.data.variants import make_variants
from spl_al.dense_probe import local_depth_features
from spl_al.experiment.data_steps import make_dataset
from spl_al.pool import initial_labeled_set
from spl_al.training.compute import Compute

FRACTIONS = (0.02, 0.05, 0.10, 0.25, 1.0)
SEEDS = (1, 2, 3)
LINEAR_SIZE = 16


# ---------------------------------------------------------------- the validation split


def tuning_split(
    dataset, fraction: float = VALIDATION_FRACTION, seed: int = VALIDATION_SEED
) -> tuple[np.ndarray, np.ndarray]:
    """(fit, validation) sample indices: the training pool cut by ``validation_split``,
    stratified by class for classification; the test split is not read."""
    pool = dataset.train_idx
    labels = dataset.labels[pool] if dataset.task == "classification" else None
    return validation_split(pool, fraction, seed, labels=labels)


# ---------------------------------------------------------------- linear references


def _linear_image_features(depth_m, valid) -> np.ndarray:
    """(n, 2 * 16 * 16): standardised depth and validity, bilinearly downsampled."""
    # torch on demand (importing this module does not load it)
    import torch.nn.functional as F

    from spl_al.models import to_input

    x = to_input(depth_m, valid)
    small = F.interpolate(x, size=(LINEAR_SIZE, LINEAR_SIZE), mode="bilinear", align_corners=False)
    return small.reshape(len(x), -1).numpy()


def linear_reference(dataset, labeled: np.ndarray, held_out: np.ndarray, seed: int) -> float:
    """Accuracy (mIoU) on samples ``held_out`` of the linear reference trained on
    samples ``labeled``."""
    from sklearn.linear_model import LogisticRegression
    from sklearn.preprocessing import StandardScaler

    val = np.asarray(held_out)
    if dataset.task == "classification":
        x_tr = _linear_image_features(dataset.depth_m[labeled], dataset.valid[labeled])
        y_tr = dataset.labels[labeled]
        x_val = _linear_image_features(dataset.depth_m[val], dataset.valid[val])
        if np.unique(y_tr).size < 2:
            return float(np.mean(dataset.labels[val] == y_tr[0]))
        clf = LogisticRegression(max_iter=2000).fit(x_tr, y_tr)
        return float(np.mean(clf.predict(x_val) == dataset.labels[val]))
    # torch on demand (importing this module does not load it)
    from spl_al.training.metrics import confusion_per_image, segmentation_summary

    f_tr = local_depth_features(dataset.depth_m[labeled], dataset.valid[labeled])
    keep = dataset.valid[labeled] & (dataset.labels[labeled] != 255)
    x_tr, y_tr = f_tr[keep], dataset.labels[labeled][keep]
    rng = np.random.default_rng(seed)
    if len(y_tr) > 60_000:  # plenty for 9 features; keeps the fit to seconds
        pick = rng.choice(len(y_tr), 60_000, replace=False)
        x_tr, y_tr = x_tr[pick], y_tr[pick]
    scaler = StandardScaler().fit(x_tr)
    clf = LogisticRegression(max_iter=500).fit(scaler.transform(x_tr), y_tr)
    f_val = local_depth_features(dataset.depth_m[val], dataset.valid[val])
    pred = clf.predict(scaler.transform(f_val.reshape(-1, f_val.shape[-1]))).reshape(
        f_val.shape[:3]
    )
    target = np.where(dataset.valid[val], dataset.labels[val], 255)
    conf = confusion_per_image(pred, target, len(dataset.classes)).sum(0)
    return float(segmentation_summary(conf, dataset.classes)["miou"])


# ---------------------------------------------------------------- the learner


def learner_score(
    dataset,
    labeled: np.ndarray,
    held_out: np.ndarray,
    *,
    model_cfg: dict,
    fit_cfg: dict,
    seed: int,
    variants: bool,
    compute=None,
) -> float:
    """Accuracy (mIoU) on the observed images of samples ``held_out`` of the configured
    model trained on samples ``labeled`` (with their variants when ``variants``), as a
    pipeline round trains it, on ``compute`` (``Compute``; None: ``LOCAL``, fp32)."""
    # torch on demand (importing this module does not load it)
    from spl_al.models.configured import model_for
    from spl_al.training import evaluate
    from spl_al.training.groups import train_groups

    model, _fit, _ = train_groups(
        dataset,
        labeled,
        given=dataset.labels[labeled],
        model=model_for(dataset, model_cfg),
        fit={**fit_cfg, "log_every": 0},
        n_variants=dataset.n_variants if variants else 0,
        seed=seed,
        compute=compute,
        log=_Null(),
    )
    val = np.asarray(held_out)
    metrics = evaluate(
        model, dataset.depth_m[val], dataset.valid[val], dataset.labels[val], compute=compute
    )
    return float(metrics[HEADLINE_METRICS[dataset.task]])


class _Null:
    def write(self, _text: str) -> None:
        pass

    def flush(self) -> None:
        pass


def budgets(n_pool: int, fractions=FRACTIONS) -> list[int]:
    """Labeled-group counts for ``fractions`` of a pool of ``n_pool`` (at least 2 each)."""
    return sorted({min(n_pool, max(2, round(f * n_pool))) for f in fractions})


def learning_curves(
    dataset,
    model_cfg: dict,
    fit_cfg: dict,
    *,
    fractions=FRACTIONS,
    seeds=SEEDS,
    log=print,
    val_fraction: float = VALIDATION_FRACTION,
    val_seed: int = VALIDATION_SEED,
    compute=None,
) -> list[dict]:
    """One row per budget: the budget and the validation scores of every seed (linear
    reference, learner on observed images, learner with variants), labeled sets drawn
    from the fit part of ``tuning_split(dataset, val_fraction, val_seed)``; the learner
    on ``compute`` (``learner_score``)."""
    pool, held_out = tuning_split(dataset, val_fraction, val_seed)
    rows = []
    for size in budgets(len(pool), fractions):
        row = {
            "n": size,
            "fraction": size / len(pool),
            "linear": [],
            "observed": [],
            "variants": [],
        }
        for seed in seeds:
            labeled = pool[initial_labeled_set(len(pool), size, seed)]
            start = time.perf_counter()
            row["linear"].append(linear_reference(dataset, labeled, held_out, seed))
            recipe = {"model_cfg": model_cfg, "fit_cfg": fit_cfg, "seed": seed, "compute": compute}
            row["observed"].append(
                learner_score(dataset, labeled, held_out, **recipe, variants=False)
            )
            if dataset.n_variants:
                row["variants"].append(
                    learner_score(dataset, labeled, held_out, **recipe, variants=True)
                )
            log(
                f"  n={size} seed={seed}: linear {row['linear'][-1]:.3f} "
                f"observed {row['observed'][-1]:.3f} "
                + (f"variants {row['variants'][-1]:.3f} " if row["variants"] else "")
                + f"({time.perf_counter() - start:.0f} s)"
            )
        rows.append(row)
    return rows


def _cell(values: list[float]) -> str:
    if not values:
        return "-"
    return f"{100 * np.mean(values):.1f} ± {100 * np.std(values):.1f}"


def table_rows(name: str, rows: list[dict]) -> list[list[str]]:
    """Markdown table rows of one dataset's learnability ``rows``."""
    return [
        [
            name,
            f"{r['n']} ({100 * r['fraction']:.0f}%)",
            _cell(r["linear"]),
            _cell(r["observed"]),
            _cell(r["variants"]),
            f"{100 * (np.mean(r['variants'] or r['observed']) - np.mean(r['linear'])):+.1f}",
        ]
        for r in rows
    ]


HEADER = ["dataset", "labeled groups", "linear ref.", "learner", "learner + variants", "gain"]


# ---------------------------------------------------------------- command line


def default_datasets(config_path: Path, names: list[str] | None, cache: Path):
    """(name, Dataset, model_cfg, fit_cfg) for the config's datasets, synthesised as
    the pipeline makes them (cached under ``cache``)."""
    import yaml

    config = yaml.safe_load(config_path.read_text())
    for name, entry in config["datasets"].items():
        if names and name not in names:
            continue
        path = cache / f"{name}.npz"
        if not path.exists():
            make_dataset(entry, cache / f"{name}_observed.npz")
            data = Dataset.load(cache / f"{name}_observed.npz")
            v = entry["variants"]
            data = make_variants(data, n_variants=int(v["n"]), seed=int(v["seed"]))
            data.save(path)
        yield name, Dataset.load(path), entry["train"]["model"], entry["train"]["fit"]


def recipe_overrides(items: list[str]) -> dict:
    """``["fit.mixup=0.4", "model.width=32"]`` -> {"model": {"width": 32}, "fit": {...}};
    values are read as YAML (numbers, true/false, lists)."""
    import yaml

    out: dict = {"model": {}, "fit": {}}
    for item in items:
        key, sep, value = item.partition("=")
        section, _, name = key.partition(".")
        if not sep or section not in out or not name:
            raise ValueError(
                f"--set takes model.KEY=VALUE or fit.KEY=VALUE (e.g. fit.mixup=0.4), got {item!r}."
            )
        out[section][name] = yaml.safe_load(value)
    return out


def add_compute_arguments(parser: argparse.ArgumentParser) -> None:
    """``--precision`` and ``--threads``: where the learner trains (``compute_of``)."""
    parser.add_argument(
        "--precision",
        choices=["fp32", "bf16", "fp16", "auto"],
        default="fp32",
        help="of the learner's training and scoring (default fp32)",
    )
    parser.add_argument("--threads", type=int, default=None, help="torch threads")


def compute_of(args: argparse.Namespace):
    """The ``Compute`` of ``--precision`` and ``--threads``, its threads applied."""
    compute = Compute(precision=args.precision, threads=args.threads)
    compute.apply()
    return compute


def main(argv: list[str] | None = None) -> int:
    """Run the learnability benchmark on ``argv``'s datasets; print its tables; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench learnability")
    parser.add_argument("datasets", nargs="*", type=Path, help="dataset .npz files (with variants)")
    parser.add_argument("--config", type=Path, default=Path("config/config.yaml"))
    parser.add_argument("--only", nargs="*", help="config datasets to run (default: all)")
    parser.add_argument("--seeds", type=int, nargs="*", default=list(SEEDS))
    parser.add_argument("--fractions", type=float, nargs="*", default=list(FRACTIONS))
    parser.add_argument(
        "--val-fraction",
        type=float,
        default=VALIDATION_FRACTION,
        help="share of the training pool (of each class) held out for scoring",
    )
    parser.add_argument(
        "--val-seed", type=int, default=VALIDATION_SEED, help="seed of the validation split"
    )
    parser.add_argument("--cache", type=Path, default=None, help="folder for synthesised data")
    parser.add_argument("--no-digits", action="store_true", help="skip the SPL digits folder")
    parser.add_argument(
        "--set",
        nargs="*",
        default=[],
        metavar="KEY=VALUE",
        help="override the recipe of every dataset, e.g. fit.mixup=0.4 model.width=32",
    )
    add_compute_arguments(parser)
    args = parser.parse_args(argv)
    overrides = recipe_overrides(args.set)
    compute = compute_of(args)

    import yaml

    cache = args.cache or Path(tempfile.mkdtemp(prefix="spl-al-learnability-"))
    cache.mkdir(parents=True, exist_ok=True)
    entries = []
    if not args.datasets:
        entries = list(default_datasets(args.config, args.only, cache))
    # External data get the recipe of the config's first classification dataset.
    config = yaml.safe_load(args.config.read_text())
    cls_entry = next(e for e in config["datasets"].values() if e["task"] == "classification")
    seg_entry = next(
        (e for e in config["datasets"].values() if e["task"] == "segmentation"), cls_entry
    )
    external = list(args.datasets)
    if not args.datasets and not args.no_digits:
        path = cache / "spl_digits.npz"
        if not path.exists():
            folder = write_digits_folder(cache / "spl_digits", n_per_class=100)
            data = make_variants(load_folder(folder), n_variants=4, seed=0)
            data.save(path)
        external.append(path)
    for path in external:
        data = Dataset.load(path)
        entry = cls_entry if data.task == "classification" else seg_entry
        entries.append((path.stem, data, entry["train"]["model"], entry["train"]["fit"]))

    lines = []
    for name, data, model_cfg, fit_cfg in entries:
        model_cfg = {**model_cfg, **overrides["model"]}
        fit_cfg = {**fit_cfg, **overrides["fit"]}
        fit, val = tuning_split(data, args.val_fraction, args.val_seed)
        print(
            f"{name}: {len(data.train_idx)} training groups = {len(fit)} fit + {len(val)} "
            f"validation, M = {data.n_variants}",
            flush=True,
        )
        rows = learning_curves(
            data, model_cfg, fit_cfg, fractions=args.fractions, seeds=args.seeds,
            val_fraction=args.val_fraction, val_seed=args.val_seed, compute=compute,
        )  # fmt: skip
        lines += table_rows(name, rows)
    print()
    print(
        f"validation accuracy (segmentation: mIoU) in %, mean ± std over seeds {args.seeds}; "
        f"validation split: {args.val_fraction} of the training pool, seed {args.val_seed} "
        "(labeled groups: of its fit part); "
        "gain = learner (with variants when present) minus linear reference"
    )
    print(markdown_table(HEADER, lines))
    return 0

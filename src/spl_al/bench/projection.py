"""GPU-hours of a protocol, projected from FLOP counts: ``python -m spl_al.bench projection``.

A projection, not a measurement. For each dataset of a config (default
config/paper.yaml over config/config.yaml):

- FLOPs per image: one training step (forward + backward) and one forward pass of the
  dataset's model at its image size, counted by ``torch.utils.flop_counter.FlopCounterMode``
  (convolutions and matrix products; PointNet++'s sampling and neighbour searches are
  not counted, so its rows are marked and best replaced by a measured rate, ``--rate``);
- images of the whole protocol: every training job the workflow runs (train_initial
  once per seed and number of variants, then every (method, seed) round of
  ``spl_al.experiment.plan.dataset_runs``), each ``TrainConfig.total_steps`` x batch
  images, plus one forward pass over the test split per round and over the pool
  (observed images and the variants the method uses) for every round a query follows;
- CPU rate here: ``spl_al.bench.training.measure`` (fp32, ``--threads``) for the
  classifier and U-Net datasets, turned into achieved GFLOP/s;
- GPU-hours = FLOPs / (peak x utilisation), with the peak dense tensor throughput of the
  named GPU (``--peak-tflops``, default an H100 SXM's 989 bf16 TFLOP/s) and an assumed
  utilisation (``--utilisation``, default 0.15). This is compute only: small labeled
  sets give small batches that a GPU runs far below peak, and every job pays its
  process start, so the table also gives the jobs and optimiser steps to which a
  per-job and per-step cost can be applied.
"""

from __future__ import annotations

import argparse
import copy
import os
import time
from pathlib import Path

import yaml

from spl_al.bench.timing import markdown_table
from spl_al.bench.training import case_model, measure, random_data
from spl_al.config import drop_removed, select_datasets
from spl_al.experiment.shared_embedding import share_embeddings
from spl_al.training import TrainConfig

ROOT = Path(__file__).resolve().parents[3]


def merged_config(paths: list[Path]) -> dict:
    """config/config.yaml with ``paths`` merged on top as Snakemake merges --configfile
    (nested dicts key by key, anything else replaced; null entries removed)."""

    def update(base: dict, over: dict) -> None:
        for key, value in over.items():
            if isinstance(value, dict) and isinstance(base.get(key), dict):
                update(base[key], value)
            else:
                base[key] = copy.deepcopy(value)

    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    user: dict = {}
    for path in paths:
        override = yaml.safe_load(Path(path).read_text()) or {}
        update(config, override)
        update(user, override)
    config = drop_removed(config)
    select_datasets(config, user)  # only_datasets: exactly the datasets it lists
    share_embeddings(config)  # embedding: {shared: SOURCE}, as the Snakefile resolves it
    return config


def split_sizes(entry: dict) -> tuple[int, int, int]:
    """(pool groups, test images, classes) of a dataset entry from its synthesis block."""
    syn = entry.get("synthesis", {})
    if entry["task"] == "classification":
        n_classes = 11
        n = int(syn.get("n_per_class", 100)) * n_classes
    else:
        n_classes = 8
        n = int(syn["n_samples"])
    n_test = round(n * float(syn.get("test_fraction", 0.3)))
    return n - n_test, n_test, n_classes


def method_variants(config: dict, dataset: str, method: str) -> int:
    """Variants per labeled group that ``method`` trains on (0: observed images only)."""
    # pandas on demand (importing this module does not load it)
    from spl_al.experiment.plan import dataset_method

    n_variants = int(config["datasets"][dataset]["variants"]["n"])
    return dataset_method(config, dataset, method).train_variants(n_variants)


def protocol_images(config: dict, dataset: str) -> dict:
    """Training jobs, optimiser steps, training images and forward-pass images of a
    dataset's protocol."""
    # pandas on demand (importing this module does not load it)
    from spl_al.experiment.plan import dataset_runs, labeled_at

    entry = config["datasets"][dataset]
    n_pool, n_test, _ = split_sizes(entry)
    al = entry["al"]
    fit = {k: v for k, v in entry["train"]["fit"].items() if v is not None}
    cfg = TrainConfig.from_dict(fit)

    def train_steps(groups: int, m: int) -> tuple[int, int]:
        n = groups * (1 + m)
        return cfg.total_steps(n, groups), min(cfg.batch_size, n)

    def forward_images(groups: int, m: int, scored: bool) -> int:
        # evaluate on the test split, then score the pool for the next query
        return n_test + ((n_pool - groups) * (1 + m) if scored else 0)

    jobs = steps = train = forward = largest = 0
    initial = set()
    for (method, seed), rounds in dataset_runs(config, dataset).items():
        m = method_variants(config, dataset, method)
        for r in range(rounds):
            groups = labeled_at(al, r)
            if r == 0:
                if (seed, m) in initial:
                    continue  # train_initial: one fit per seed and variants per group
                initial.add((seed, m))
            n_steps, batch = train_steps(groups, m)
            jobs += 1
            steps += n_steps
            train += n_steps * batch
            largest = max(largest, n_steps * batch)
            forward += forward_images(groups, m, scored=r + 1 < rounds)
    return {
        "jobs": jobs,
        "steps": steps,
        "train_images": train,
        "forward_images": forward,
        "largest_job_images": largest,
    }


def model_case(config: dict, dataset: str):
    """(task, model, model config, fit dict, image shape, n_classes) of a dataset."""
    entry = config["datasets"][dataset]
    shape = tuple(entry["synthesis"]["image_shape"])
    _, _, n_classes = split_sizes(entry)
    model_cfg = {k: v for k, v in entry["train"].get("model", {}).items() if v is not None}
    fit = {k: v for k, v in entry["train"]["fit"].items() if v is not None}
    model = case_model(entry["task"], model_cfg, shape, n_classes)
    return entry["task"], model, model_cfg, fit, shape, n_classes


def flops_per_image(
    task: str, model, *, shape, n_classes: int, batch: int = 8
) -> tuple[float, float]:
    """(training step FLOPs, forward FLOPs) per image, counted on a batch of ``batch``."""
    # torch on demand (importing this module does not load it)
    import torch
    from torch.utils.flop_counter import FlopCounterMode

    from spl_al.models import model_input

    depth, valid, targets = random_data(task, shape, n=batch, n_classes=n_classes)
    x = model_input(model, depth, valid)
    y = torch.as_tensor(targets).long()
    model.train()
    with FlopCounterMode(display=False) as counter:
        out = model(x)
        logits = out[0] if isinstance(out, tuple) else out
        torch.nn.functional.cross_entropy(logits, y).backward()
    train = counter.get_total_flops() / batch
    model.eval()
    with torch.no_grad(), FlopCounterMode(display=False) as counter:
        model(x)
    return train, counter.get_total_flops() / batch


def main(argv: list[str]) -> int:
    """Print the projection table for every dataset of the config; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench projection", description=__doc__)
    parser.add_argument("--configfile", type=Path, nargs="*", default=[ROOT / "config/paper.yaml"])
    parser.add_argument("--only", nargs="*", help="datasets to project (default: all)")
    parser.add_argument("--threads", type=int, default=2, help="CPU threads of the measured rate")
    parser.add_argument("--steps", type=int, default=4, help="timed CPU training steps")
    parser.add_argument("--gpu", default="NVIDIA H100 SXM (assumed)", help="name in the table")
    parser.add_argument("--peak-tflops", type=float, default=989.0, help="dense bf16 peak")
    parser.add_argument("--utilisation", type=float, default=0.15, help="assumed share of peak")
    parser.add_argument(
        "--rate", action="append", default=[], metavar="DATASET=IMAGES_PER_S",
        help="a measured GPU training rate that replaces the FLOP projection",
    )  # fmt: skip
    args = parser.parse_args(argv)
    if not 0 < args.utilisation <= 1:
        parser.error(f"--utilisation must be in (0, 1], got {args.utilisation}.")
    rates = {}
    for item in args.rate:
        name, _, value = item.partition("=")
        try:
            rates[name] = float(value)
        except ValueError:
            parser.error(f"--rate must read DATASET=IMAGES_PER_S, got {item!r}.")

    config = merged_config(args.configfile)
    effective = args.peak_tflops * 1e12 * args.utilisation
    print(
        f"## GPU-hours projected from FLOP counts (projection, not measured): {args.gpu}, "
        f"peak {args.peak_tflops:g} TFLOP/s x utilisation {args.utilisation:g}; CPU rate: "
        f"{args.threads} threads, load average {os.getloadavg()[0]:.2f} on "
        f"{os.cpu_count()} cores, {time.strftime('%Y-%m-%d')}\n",
        flush=True,
    )
    rows = []
    for dataset in config["datasets"]:
        if args.only and dataset not in args.only:
            continue
        task, model, model_cfg, fit, shape, n_classes = model_case(config, dataset)
        arch = model_cfg.get("arch") or type(model).__name__
        train_flops, fwd_flops = flops_per_image(task, model, shape=shape, n_classes=n_classes)
        counts = protocol_images(config, dataset)
        total = counts["train_images"] * train_flops + counts["forward_images"] * fwd_flops
        cpu_cell = "-"
        if arch != "pointnet2":
            cpu_fit = {**fit, "batch_size": min(int(fit.get("batch_size", 32)), 32)}
            rate, _ = measure(
                task,
                model_cfg,
                cpu_fit,
                shape=shape,
                precision="fp32",
                threads=args.threads,
                steps=args.steps,
            )
            cpu_cell = f"{rate * train_flops / 1e9:.0f}"
        largest = counts["largest_job_images"]
        if dataset in rates:
            hours = counts["train_images"] / rates[dataset] / 3600
            largest_min = largest / rates[dataset] / 60
            how = f"measured {rates[dataset]:g} images/s"
        else:
            hours = total / effective / 3600
            largest_min = largest * train_flops / effective / 60
            how = "FLOPs" + (" (sampling not counted)" if arch == "pointnet2" else "")
        rows.append(
            [dataset, str(arch), "x".join(map(str, shape)), f"{train_flops / 1e9:.2f}",
             str(counts["jobs"]), f"{counts['steps']:,}", f"{counts['train_images'] / 1e6:.2f}",
             f"{total / 1e15:.1f}", cpu_cell, f"{hours:.2f}", f"{largest_min:.1f}", how]
        )  # fmt: skip
        print(" | ".join(rows[-1]), flush=True)
    print()
    header = ["dataset", "model", "image", "train GFLOP/image", "train jobs", "steps",
              "train Mimages",
              "PFLOP total", "CPU GFLOP/s here", "GPU-hours", "largest job GPU-min",
              "from"]  # fmt: skip
    print(markdown_table(header, rows))
    return 0

"""Training throughput per precision: ``python -m spl_al.bench training [--threads 1,2]``.

For each default model (config/config.yaml's real_cls classifier, street_seg U-Net and
street_pc PointNet++, and config/paper.yaml's ResNet-18) at fp32 and at every other
precision this machine runs (``spl_al.training.precision``: bf16 on any CPU, natively
only with AVX512-BF16/AMX; fp16 and bf16 on CUDA), on 1 and 2 CPU threads (and on CUDA
when torch sees a GPU): images (clouds) per second of

- training: ``spl_al.training.train`` itself with the dataset's own recipe (input
  building, augmentation, SGD step), ``--steps`` steps timed after a warm-up run in
  the same process, images/s = steps x batch / seconds;
- inference: ``spl_al.training.forward`` over 4 batches (the forward passes of
  evaluation and scoring), after one warm-up pass.

Inputs are random depth images (and masks) of the dataset's shape: throughput does not
depend on what the pixels hold. "x fp32" is the training speed over fp32 at the same
threads; ``auto`` names the precision the config's ``precision: auto`` picks here.
"""

from __future__ import annotations

import argparse
import io
import os
import time
from pathlib import Path

import yaml

from spl_al.bench.timing import markdown_table

ROOT = Path(__file__).resolve().parents[3]


def _cases(config: dict, paper: dict) -> list[tuple[str, str, dict, dict, tuple[int, int]]]:
    """(label, task, model cfg, fit cfg, image shape) of each default model."""
    data = config["datasets"]
    real = data["real_cls"]
    seg, pc = data["street_seg"], data["street_pc"]
    resnet = {k: v for k, v in paper["datasets"]["real_cls"]["train"]["model"].items() if v}
    return [
        ("classifier (real_cls)", "classification", real["train"]["model"],
         real["train"]["fit"], tuple(real["synthesis"]["image_shape"])),
        ("U-Net (street_seg)", "segmentation", seg["train"]["model"], seg["train"]["fit"],
         tuple(seg["synthesis"]["image_shape"])),
        ("PointNet++ (street_pc)", "segmentation", pc["train"]["model"], pc["train"]["fit"],
         tuple(pc["synthesis"]["image_shape"])),
        ("ResNet-18 (paper.yaml), batch 32", "classification", resnet,
         {**real["train"]["fit"], "batch_size": 32}, tuple(real["synthesis"]["image_shape"])),
    ]  # fmt: skip


def random_data(task: str, shape, *, n: int, n_classes: int, seed: int = 0):
    """(depth, valid, targets) of ``n`` random images: 10% voids, random labels (or masks)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    depth = rng.uniform(2, 40, size=(n, *shape)).astype(np.float32)
    valid = rng.random(depth.shape) > 0.1
    depth[~valid] = np.nan
    if task == "classification":
        targets = rng.integers(0, n_classes, n)
    else:
        targets = rng.integers(0, n_classes, (n, *shape)).astype(np.uint8)
    return depth, valid, targets


def case_model(task: str, model_cfg: dict, shape, n_classes: int):
    """The model a bench case times: ``model_cfg`` built for ``shape`` (with the scanning
    grid where the architecture needs one)."""
    # torch on demand (importing this module does not load it)
    from spl_al.models import build_model, needs_grid

    cfg = dict(model_cfg)
    arch = cfg.pop("arch", None)
    if needs_grid(task, arch):
        # numpy on demand (importing this module does not load it)
        from spl_al.scenes.street import default_grid

        cfg["grid"] = default_grid(shape)
    return build_model(task, n_classes, arch=arch, **cfg)


def measure(
    task, model_cfg, fit, *, shape, precision, threads, steps, device="cpu", infer_precision=None
):
    """(train images/s, inference images/s) of one case; inference at ``infer_precision``
    (default: ``precision``)."""
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.training import Compute, TrainConfig, predict, train

    torch.set_num_threads(threads)
    training = Compute(device, precision=precision)
    inference = Compute(device, precision=infer_precision or precision)
    n_classes = 11 if task == "classification" else 8
    batch = int(fit.get("batch_size", 32))
    depth, valid, targets = random_data(task, shape, n=4 * batch, n_classes=n_classes)
    model = case_model(task, model_cfg, shape, n_classes)
    fit = {k: v for k, v in fit.items() if k not in ("epochs", "min_steps", "steps_per_group")}
    rates = []
    for run_steps in (2, steps):  # the first run warms up
        cfg = TrainConfig.from_dict({**fit, "steps": run_steps, "epochs": None, "log_every": 0})
        sync(device)
        start = time.perf_counter()
        train(model, depth, valid, targets, cfg=cfg, seed=0, compute=training, log=io.StringIO())
        sync(device)
        rates.append(run_steps * batch / (time.perf_counter() - start))
    predict(
        model,
        depth[:batch],
        valid[:batch],
        compute=inference,
        batch_size=batch,
        features="none",
    )
    sync(device)
    start = time.perf_counter()
    predict(
        model,
        depth,
        valid,
        compute=inference,
        batch_size=batch,
        features="none",
    )
    sync(device)
    return rates[-1], len(depth) / (time.perf_counter() - start)


def sync(device: str) -> None:
    """Wait for the GPU (a no-op on the CPU) so that a timer sees finished work."""
    if device != "cpu":
        import torch

        torch.cuda.synchronize()


def main(argv: list[str]) -> int:
    """Time every default model at every precision; print the table; the exit code."""
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.models import model_class
    from spl_al.training.precision import native_bf16, resolve_precision

    parser = argparse.ArgumentParser(prog="python -m spl_al.bench training", description=__doc__)
    parser.add_argument("--threads", default="1,2", help="CPU thread counts, comma-separated")
    parser.add_argument("--steps", type=int, default=20, help="timed training steps per case")
    parser.add_argument("--only", default=None, help="cases whose label contains this text")
    args = parser.parse_args(argv)
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    paper = yaml.safe_load((ROOT / "config" / "paper.yaml").read_text())
    cpu = torch.device("cpu")
    places = [("cpu", int(t), ["fp32", "bf16"]) for t in args.threads.split(",")]
    if torch.cuda.is_available():
        places.append(("cuda", 0, ["fp32", "bf16", "fp16"]))
    auto = resolve_precision("auto", cpu)
    print(
        f"## Training throughput (load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} "
        f"cores; CPU bf16 native: {native_bf16(cpu)}; auto = {auto} on the CPU)\n",
        flush=True,
    )
    rows = []
    for label, task, model_cfg, fit, shape in _cases(config, paper):
        if args.only and args.only not in label:
            continue
        # what `precision: auto` picks for this model (PointNet++ stays fp32 on a CPU)
        model_auto = resolve_precision("auto", cpu, model_class(task, model_cfg.get("arch")))
        for device, threads, precisions in places:
            base = None
            for precision in precisions:
                train_rate, infer_rate = measure(
                    task,
                    model_cfg,
                    fit,
                    shape=shape,
                    precision=precision,
                    threads=max(threads, 1),
                    steps=args.steps,
                    device=device,
                )
                base = base or train_rate
                name = torch.cuda.get_device_name(0) if device == "cuda" else "cpu"
                auto_here = device == "cpu" and precision == model_auto
                tag = f"{precision} (auto)" if auto_here else precision
                rows.append(
                    [label, name, tag, str(threads) if device == "cpu" else "-",
                     str(fit.get("batch_size")), f"{train_rate:.0f}", f"{train_rate / base:.2f}",
                     f"{infer_rate:.0f}"]
                )  # fmt: skip
                print(" | ".join(rows[-1]), flush=True)
    print()
    header = ["model", "device", "precision", "threads", "batch", "images/s", "x fp32"]
    print(markdown_table([*header, "inference images/s"], rows))
    print(
        "\nimages/s: training steps x batch / s of spl_al.training.train (PointNet++: "
        "clouds); x fp32: over fp32 at the same threads."
    )
    return 0

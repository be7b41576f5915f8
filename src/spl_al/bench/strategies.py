"""Benchmark the acquisition strategies and training throughput on this machine.

``python -m spl_al.bench strategies [--pool 20000 --dim 512 --classes 11 --m 4
--batch 100 --n-cand 500 --labeled 1000 --only NAME ... --skip-training]``

Prints Markdown tables: time and peak memory of coreset, badge and duis, and of
scikit-activeml's typiclust, probcover and maxherding (when installed: the extra
spl-al[baselines]), on a synthetic unlabeled pool, then training throughput
(images/s) of the default CPU classifier and of ResNet-18 at 64x64 next to the
measured matrix-multiply FLOP/s.
Peak memory is measured twice: the peak of numpy allocations made during the call
(tracemalloc) and the growth of the process's resident-set high-water mark (Linux).
The scikit-activeml strategies are timed once, with the resident-set growth only:
tracemalloc needs a second call, and on a 20k pool each is minutes (ProbCover and
MaxHerding hold 20k x 20k matrices).
"""

from __future__ import annotations

import argparse
import gc
import io
import os
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np

from spl_al.strategies import StrategyInputs, get
from spl_al.strategies.duis import margin_and_inconsistency

_STATUS = Path("/proc/self/status")
_CLEAR_REFS = Path("/proc/self/clear_refs")


def _rss_kib(field: str) -> int | None:
    try:
        for line in _STATUS.read_text().splitlines():
            if line.startswith(field + ":"):
                return int(line.split()[1])
    except OSError:
        pass
    return None


def _reset_peak_rss() -> bool:
    try:
        _CLEAR_REFS.write_text("5")  # resets VmHWM to the current RSS (Linux >= 4.0)
        return True
    except OSError:
        return False


def measure(fn: Callable[[], object], traced: bool = True) -> dict:
    """Wall time, tracemalloc peak (a second call; None without ``traced``) and RSS
    high-water growth of one call of ``fn``."""
    gc.collect()
    can_reset = _reset_peak_rss()
    rss0 = _rss_kib("VmRSS")
    t0 = time.perf_counter()
    fn()
    seconds = time.perf_counter() - t0
    hwm = _rss_kib("VmHWM")
    rss_mb = (hwm - rss0) / 1024 if can_reset and hwm is not None and rss0 is not None else None
    if not traced:
        return {"seconds": seconds, "traced_mb": None, "rss_mb": rss_mb}
    gc.collect()
    tracemalloc.start()
    fn()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return {"seconds": seconds, "traced_mb": peak / 2**20, "rss_mb": rss_mb}


def synthetic_pool(
    n: int, dim: int, *, n_classes: int, m: int, n_labeled: int, seed: int = 0
) -> tuple[StrategyInputs, np.ndarray]:
    """A clustered feature pool with softmax predictions for observed image and variants.

    Returns the inputs (all needs except gamma/d) and the group probabilities
    (n, m + 1, 1, C) from which DUIS's gamma and d are computed inside the timing.
    """
    rng = np.random.default_rng(seed)
    centres = rng.normal(0, 3, (n_classes, dim)).astype(np.float32)
    cls = rng.integers(0, n_classes, n + n_labeled)
    feats = np.maximum(centres[cls] + rng.normal(0, 1, (n + n_labeled, dim)), 0).astype(np.float32)
    w = rng.normal(0, 1 / np.sqrt(dim), (dim, n_classes)).astype(np.float32)
    logits = feats[:n] @ w
    group_logits = logits[:, None] + rng.normal(0, 1, (n, m + 1, n_classes)).astype(np.float32)
    group_probs = np.exp(group_logits - group_logits.max(-1, keepdims=True))
    group_probs /= group_probs.sum(-1, keepdims=True)
    probs = group_probs[:, 0]
    q = probs.copy()
    q[np.arange(n), probs.argmax(1)] -= 1.0
    inputs = StrategyInputs(
        unlabeled_idx=np.arange(n_labeled, n_labeled + n),
        labeled_idx=np.arange(n_labeled),
        features=feats[:n],
        group_features=feats[:n] + rng.normal(0, 0.1, (n, dim)).astype(np.float32),
        labeled_features=feats[n:],
        grad_q=q.astype(np.float32),
        grad_h=feats[:n],
    )
    return inputs, group_probs[:, :, None, :]


def bench_strategies(args) -> list[list[str]]:
    """Table rows of each strategy's selection time on a synthetic pool."""
    inputs, group_probs = synthetic_pool(
        args.pool, args.dim, n_classes=args.classes, m=args.m, n_labeled=args.labeled
    )

    def duis() -> None:
        gamma, d = margin_and_inconsistency(group_probs)
        inputs.gamma, inputs.inconsistency = gamma, d
        get("duis", n_cand=args.n_cand).select(inputs, args.batch, np.random.default_rng(0))

    def run(name: str) -> Callable[[], object]:
        return lambda: get(name).select(inputs, args.batch, np.random.default_rng(0))

    targets = {"coreset": "<= 10 s, <= 500 MB", "badge": "<= 5 s", "duis": "<= 30 s"}
    cases = [("coreset", run("coreset"), True), ("badge", run("badge"), True)]
    cases.append(("duis", duis, True))
    baselines = {"probcover": {"n_classes": args.classes}}
    for name in ("typiclust", "probcover", "maxherding"):
        params = baselines.get(name, {})
        cases.append((name, lambda n=name, p=params: _select(n, p, inputs, args.batch), False))
    only = set(getattr(args, "only", None) or [c[0] for c in cases])
    rows = []
    for name, fn, traced in cases:
        if name not in only:
            continue
        try:
            r = measure(fn, traced)
        except ValueError as err:  # scikit-activeml not installed
            rows.append([name, "n/a", "n/a", "n/a", str(err)])
            continue
        rss = "n/a" if r["rss_mb"] is None else f"{r['rss_mb']:.0f}"
        mb = "n/a" if r["traced_mb"] is None else f"{r['traced_mb']:.0f}"
        rows.append([name, f"{r['seconds']:.2f}", mb, rss, targets.get(name, "")])
    return rows


def _select(name: str, params: dict, inputs: StrategyInputs, batch: int) -> np.ndarray:
    import warnings

    with warnings.catch_warnings():  # scikit-learn's convergence notes, not results
        warnings.simplefilter("ignore")
        return get(name, **params).select(inputs, batch, np.random.default_rng(0))


def matmul_gflops(size: int = 2048, repeats: int = 5) -> float:
    """Best-of-``repeats`` float32 matrix-multiply rate of torch on this machine."""
    import torch

    a, b = torch.randn(size, size), torch.randn(size, size)
    a @ b
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        a @ b
        best = min(best, time.perf_counter() - t0)
    return 2 * size**3 / best / 1e9


def forward_gflop(model, shape) -> float:
    """Multiply-add count x 2 of the convolutions and linear layers for one image."""
    import torch
    from torch import nn

    total = [0]

    def hook(mod, inp, out) -> None:
        if isinstance(mod, nn.Conv2d | nn.ConvTranspose2d):
            kernel = mod.in_channels // mod.groups * mod.kernel_size[0] * mod.kernel_size[1]
            total[0] += out.numel() * kernel
        elif isinstance(mod, nn.Linear):
            total[0] += out.numel() * mod.in_features

    handles = [m.register_forward_hook(hook) for m in model.modules()]
    model.eval()
    with torch.no_grad():
        model(torch.zeros(1, *shape))
    for h in handles:
        h.remove()
    return 2 * total[0] / 1e9


def _throughput(task: str, arch: str, shape: tuple[int, int], batch: int, steps: int, **params):
    """Training images/s of ``train`` itself (after a warm-up run) and forward GFLOP/image."""
    # torch on demand (importing this module does not load it)
    from spl_al.models import build_model
    from spl_al.training import Compute, TrainConfig, train

    rng = np.random.default_rng(0)
    n = 4 * batch
    depth = rng.uniform(0.5, 3.0, (n, *shape)).astype(np.float32)
    valid = rng.random(depth.shape) > 0.1
    y = rng.integers(0, 11, n if task == "classification" else (n, *shape))
    model = build_model(task, 11, arch, **params)
    for run_steps in (2, steps):  # the first run warms up oneDNN's kernels
        cfg = TrainConfig(steps=run_steps, batch_size=batch, log_every=0)
        t0 = time.perf_counter()
        train(model, depth, valid, y, cfg=cfg, seed=0, compute=Compute("cpu"), log=io.StringIO())
        seconds = time.perf_counter() - t0
    return steps * batch / seconds, forward_gflop(model, (2, *shape))


def bench_training(threads: list[int]) -> tuple[list[list[str]], float]:
    """Table rows of training throughput per model and torch thread count, and the
    machine's matmul GFLOP/s they are compared with."""
    import torch

    default_cls = {"input_pool": 2, "first_stride": 1, "dropout": 0.5}  # config/config.yaml
    cases = (
        (
            "default classifier (smallcnn, 2x2 input pooling), 64x64",
            "classification",
            "smallcnn",
            (64, 64),
            128,
            40,
            default_cls,
        ),
        ("ResNet-18 (ImageNet stem), 64x64", "classification", "resnet18", (64, 64), 128, 6, {}),
        (
            "default U-Net (width 16, depth 3), 64x256",
            "segmentation",
            "unet",
            (64, 256),
            16,
            10,
            {},
        ),
    )
    before = torch.get_num_threads()
    torch.set_num_threads(max(threads))
    gflops = matmul_gflops()
    rows = []
    try:
        for label, task, arch, shape, batch, steps, params in cases:
            for n_threads in threads:
                torch.set_num_threads(n_threads)
                rate, fwd = _throughput(task, arch, shape, batch, steps, **params)
                achieved = 3 * fwd * rate  # backward ~ 2x forward
                rows.append(
                    [label, str(n_threads), str(batch), f"{rate:.0f}", f"{fwd * 1e3:.1f}",
                     f"{achieved:.1f}", f"{100 * achieved / gflops:.0f}%"]
                )  # fmt: skip
    finally:
        torch.set_num_threads(before)
    return rows, gflops


def _load() -> str:
    """The 1-minute load average: other work competing for the cores skews timings."""
    try:
        return f"{os.getloadavg()[0]:.2f}"
    except OSError:
        return "n/a"


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    """Time the strategies and a training step; print the tables; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench strategies", description=__doc__)
    parser.add_argument("--pool", type=int, default=20_000, help="unlabeled groups")
    parser.add_argument("--dim", type=int, default=512, help="feature dimension d")
    parser.add_argument("--classes", type=int, default=11)
    parser.add_argument("--m", type=int, default=4, help="variants per group M")
    parser.add_argument("--batch", type=int, default=100, help="query batch N_batch")
    parser.add_argument("--n-cand", type=int, default=500, help="DUIS candidate pool N_cand")
    parser.add_argument("--labeled", type=int, default=1000, help="labeled groups (coreset)")
    parser.add_argument("--threads", default="1,2", help="torch thread counts for training")
    parser.add_argument("--only", nargs="+", help="strategies to time (default: all)")
    parser.add_argument("--skip-training", action="store_true")
    args = parser.parse_args(argv)
    load_before = _load()

    print(
        f"## Strategies: pool {args.pool} groups, d = {args.dim}, C = {args.classes}, "
        f"M = {args.m}, batch {args.batch}, N_cand = {args.n_cand}, labeled {args.labeled}\n"
    )
    header = ["strategy", "time (s)", "peak numpy (MB)", "peak RSS growth (MB)", "target"]
    print(_table(header, bench_strategies(args)))
    print(
        "\nduis includes computing gamma and d from the (pool, M+1, 1, C) probabilities. "
        "Reference: a full-distance-matrix k-center greedy takes ~43 s and ~1.6 GB here."
    )
    if not args.skip_training:
        threads = [int(t) for t in args.threads.split(",")]
        rows, gflops = bench_training(threads)
        print("\n## Training throughput (spl_al.training.train on the CPU)\n")
        header = ["model", "threads", "batch", "images/s", "forward MFLOP/img", "achieved GFLOP/s"]
        header.append(f"of matmul ({max(threads)} threads)")
        print(_table(header, rows))
        print(
            "\nachieved = 3 x forward FLOP x images/s (a backward pass costs about two forwards)."
        )
        print(
            f"\nfloat32 matrix multiply (2048^2, torch, {max(threads)} threads): "
            f"{gflops:.0f} GFLOP/s."
        )
        print(f"Load average before / after: {load_before} / {_load()} on {os.cpu_count()} cores.")
    return 0

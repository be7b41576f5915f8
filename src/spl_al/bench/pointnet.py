"""PointNet++ throughput: ``python -m spl_al.bench pointnet [--threads 1,2 --steps 3 --quick]``.

Training and inference clouds/s of ``PointNet2Seg`` (``arch: pointnet2``) at 4,096
and 16,384 points per cloud on 1 and 2 CPU threads (and on CUDA when torch sees a
GPU), plus the default config's street_pc model (512 points):

- clouds are synthetic street-like scans (ground plane, a wall at a random distance,
  10% voids) on a 64x512 grid (32,768 pixels; the default model on street_pc's 32x128);
- training: ``spl_al.training.train`` itself (input building, SGD steps, flips), timed
  after a 1-step warm-up run in the same process: clouds/s = steps x batch / seconds;
- inference: eval-mode forward passes (every valid pixel gets logits), median of 3;
- peak memory: each case runs in a fresh spawned process; "peak RSS" is that
  process's resident-set high-water mark (``resource.getrusage(...).ru_maxrss``),
  which includes the ~300-400 MB of an imported torch (the "idle" row gives that
  baseline); on CUDA the column is ``torch.cuda.max_memory_allocated`` instead.

The 4,096- and 16,384-point models are config/paper.yaml's street_pc architecture
(centres N/4, N/16, N/64, N/256; radii 0.5, 1, 2, 4 m; K = 32; width 32).
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import io
import multiprocessing
import os
import resource
import time

from spl_al.bench.timing import markdown_table

PAPER = {"radii_m": [0.5, 1.0, 2.0, 4.0], "neighbours": 32, "width": 32}
DEFAULT = {"n_points": 512, "centres": [128, 32, 8], "radii_m": [1, 3, 8], "neighbours": 16}
CASES = (
    # label, grid shape, model params, training batch
    ("default street_pc (512 points, 32x128)", (32, 128), DEFAULT, 8),
    ("paper arch, 4,096 points", (64, 512), {"n_points": 4096, **PAPER}, 8),
    ("paper arch, 16,384 points", (64, 512), {"n_points": 16384, **PAPER}, 4),
)


def _scans(n: int, shape, seed: int = 0):
    """(n, H, W) ranges of a ground plane and a wall, 10% voids; labels 0 / 1."""
    # numpy on demand (importing this module does not load it)
    import numpy as np

    from spl_al.scenes.street import default_grid

    grid = default_grid(shape)
    u = grid.directions()
    rng = np.random.default_rng(seed)
    depth = np.empty((n, *shape), dtype=np.float32)
    for i in range(n):
        t_ground = np.where(
            u[..., 2] < 0, rng.uniform(1.5, 2.0) / np.maximum(-u[..., 2], 1e-9), 1e9
        )
        depth[i] = np.minimum(np.minimum(t_ground, rng.uniform(8, 30) / u[..., 1]), 100.0)
    labels = (depth < 99).astype(np.uint8)
    valid = rng.random(depth.shape) > 0.1
    depth[~valid] = np.nan
    return grid, depth, valid, labels


def _case(label: str, shape, *, params: dict, batch: int, threads: int, steps: int, device: str):
    """One row, run in a fresh process: (train clouds/s, inference clouds/s, peak MB)."""
    # torch on demand (importing this module does not load it)
    import numpy as np
    import torch

    from spl_al.models import build_model, model_input
    from spl_al.training import Compute, TrainConfig, train

    torch.set_num_threads(threads)
    params = dict(params)
    n = params["n_points"]
    params.setdefault("centres", [n // 4, n // 16, n // 64, n // 256])
    grid, depth, valid, labels = _scans(2 * batch, shape)
    model = build_model("segmentation", 2, "pointnet2", seed=0, grid=grid, **params)
    if device == "cuda":
        torch.cuda.reset_peak_memory_stats()
    for run_steps in (1, steps):  # the first run warms up
        cfg = TrainConfig(steps=run_steps, batch_size=batch, log_every=0, channels_last=False)
        if device == "cuda":
            torch.cuda.synchronize()
        start = time.perf_counter()
        train(
            model, depth, valid, labels, cfg=cfg, seed=0, compute=Compute(device), log=io.StringIO()
        )
        if device == "cuda":
            torch.cuda.synchronize()
        train_s = time.perf_counter() - start
    x = model_input(model, depth[:batch], valid[:batch]).to(device)
    model.eval()
    times = []
    with torch.inference_mode():
        for _ in range(4):
            start = time.perf_counter()
            model(x)
            if device == "cuda":
                torch.cuda.synchronize()
            times.append(time.perf_counter() - start)
    infer_s = float(np.median(times[1:]))
    if device == "cuda":
        peak_mb = torch.cuda.max_memory_allocated() / 2**20
    else:
        peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return steps * batch / train_s, batch / infer_s, peak_mb


def _idle() -> float:
    import torch  # noqa: F401 - the baseline is an imported torch

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _in_fresh_process(fn, *args, **kwargs):
    ctx = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
        return pool.submit(fn, *args, **kwargs).result()


def main(argv: list[str]) -> int:
    """Time the point-cloud segmenter's training steps; print the table; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench pointnet", description=__doc__)
    parser.add_argument("--threads", default="1,2", help="CPU thread counts, comma-separated")
    parser.add_argument("--steps", type=int, default=3, help="timed training steps per case")
    parser.add_argument("--quick", action="store_true", help="the default model only")
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error("--steps must be >= 1")
    threads = [int(t) for t in args.threads.split(",")]
    cases = CASES[:1] if args.quick else CASES
    import torch

    devices = [("cpu", t) for t in threads]
    if torch.cuda.is_available():
        devices.append(("cuda", 1))
    load = os.getloadavg()[0]
    print(f"## PointNet++ throughput (load average {load:.2f} on {os.cpu_count()} cores)\n")
    rows = [["idle (import torch)", "cpu", "-", "-", "-", "-", f"{_in_fresh_process(_idle):.0f}"]]
    for label, shape, params, batch in cases:
        for device, n_threads in devices:
            train_rate, infer_rate, peak = _in_fresh_process(
                _case,
                label,
                shape,
                params=params,
                batch=batch,
                threads=n_threads,
                steps=args.steps,
                device=device,
            )
            where = "cpu" if device == "cpu" else torch.cuda.get_device_name(0)
            rows.append(
                [label, where, str(n_threads) if device == "cpu" else "-", str(batch),
                 f"{train_rate:.2f}", f"{infer_rate:.2f}", f"{peak:.0f}"]
            )  # fmt: skip
            print(" | ".join(rows[-1]), flush=True)
    header = ["model", "device", "threads", "batch", "train clouds/s", "infer clouds/s"]
    header.append("peak MB")
    print()
    print(markdown_table(header, rows))
    print(
        "\npeak MB: CPU = the case process's ru_maxrss (torch included, see idle); "
        "CUDA = torch.cuda.max_memory_allocated."
    )
    if not torch.cuda.is_available():
        print("No CUDA device visible: no GPU row.")
    return 0

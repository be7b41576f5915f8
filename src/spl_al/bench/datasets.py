"""Dataset generation benchmark: ``python -m spl_al.bench datasets [options]``.

Times the default classification dataset end to end, as the pipeline makes it:
procedural scenes and their observed SPL images, M SIV variants per image, then
save and load; optionally a small segmentation dataset too. Prints a Markdown
table with seconds and images per second per stage. Target: the default dataset
(11 classes x 100, 64x64, M = 4) in <= 60 s on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import tempfile
import time
from pathlib import Path

from spl_al.bench.timing import markdown_table
from spl_al.data import Dataset, make_classification_dataset, make_segmentation_dataset
from spl_al.data.parallel import default_workers
from spl_al.data.variants import make_variants


def _cpu_seconds() -> float:
    """CPU time of this process and of its finished (joined) worker processes."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


CPU = []  # CPU seconds of each timed call, in order


def _timed(fn):
    cpu = _cpu_seconds()
    start = time.perf_counter()
    out = fn()
    wall = time.perf_counter() - start
    CPU.append(_cpu_seconds() - cpu)
    return out, wall


def _rows(name: str, dataset_fn, n_variants: int, workers: int, folder: Path) -> list[list[str]]:
    data, t_obs = _timed(dataset_fn)
    n = len(data)
    full, t_var = _timed(lambda: make_variants(data, n_variants=n_variants, workers=workers))
    path = folder / f"{name}.npz"
    _, t_save = _timed(lambda: full.save(path))
    _, t_load = _timed(lambda: Dataset.load(path))
    total = t_obs + t_var + t_save
    c_obs, c_var, c_save = CPU[-4:-1]
    c_total = c_obs + c_var + c_save
    size_mb = os.path.getsize(path) / 1e6
    h, w = data.image_shape
    m = n * n_variants
    return [
        [
            name,
            f"scenes + observed images ({h}x{w})",
            f"{n:,}",
            f"{t_obs:.1f}",
            f"{c_obs:.1f}",
            f"{n / t_obs:.0f}",
        ],
        [
            name,
            f"SIV variants (M = {n_variants})",
            f"{m:,}",
            f"{t_var:.1f}",
            f"{c_var:.1f}",
            f"{m / t_var:.0f}",
        ],
        [
            name,
            f"save ({size_mb:.1f} MB) / load",
            f"{n + m:,}",
            f"{t_save:.2f} / {t_load:.2f}",
            f"{c_save:.1f}",
            "-",
        ],
        [
            name,
            "**total** (generate + save)",
            f"{n + m:,}",
            f"**{total:.1f}**",
            f"{c_total:.1f}",
            f"{(n + m) / total:.0f}",
        ],
    ]


def main(argv: list[str]) -> int:
    """Time dataset generation, variants and saving; print the table; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench datasets")
    parser.add_argument("--n-per-class", type=int, default=100)
    parser.add_argument("--n-variants", type=int, default=4)
    parser.add_argument("--workers", type=int, default=None, help="processes (default: all cores)")
    parser.add_argument(
        "--segmentation", type=int, default=0, help="also time N street scenes (64x256)"
    )
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    workers = default_workers() if args.workers is None else args.workers

    makers = [
        (
            "classification",
            lambda: make_classification_dataset(
                n_per_class=args.n_per_class, seed=args.seed, workers=workers
            ),
        )
    ]
    if args.segmentation:
        makers.append(
            (
                "segmentation",
                lambda: make_segmentation_dataset(
                    n_samples=args.segmentation, seed=args.seed, workers=workers
                ),
            )
        )
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, make in makers:
            rows += _rows(name, make, args.n_variants, workers, Path(tmp))
    print(
        f"Dataset generation on {workers} worker process(es), {os.cpu_count()} CPUs "
        f"({platform.machine()}); pooled ML reconstruction, MSPPP 10/5/2, SBR 0.2/1/5"
    )
    print()
    print(markdown_table(["dataset", "stage", "images", "wall s", "CPU s", "images/s"], rows))
    print()
    print(
        "CPU s: this process and its workers together; on an otherwise idle machine the "
        f"wall time is about CPU s / {workers}. Load average now: "
        + ", ".join(f"{v:.2f}" for v in os.getloadavg())
    )
    return 0

"""Process-pool map over chunks of samples (the generators are embarrassingly parallel).

Every per-sample result depends only on (seed, stream, uid) (``spl_al.data.seeds``),
so the number of workers and the chunking never change a result.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor

import numpy as np


def default_workers() -> int:
    """CPU cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def chunk_indices(n_items: int, workers: int, per_worker: int = 4) -> list[np.ndarray]:
    """Split 0..n_items-1 into contiguous chunks, ``per_worker`` per worker (for balance)."""
    n_chunks = max(1, min(n_items, workers * per_worker))
    return [c for c in np.array_split(np.arange(n_items), n_chunks) if c.size]


def run_chunks(fn: Callable, chunk_args: Sequence[tuple], workers: int | None, **shared) -> list:
    """``[fn(*args, **shared) for args in chunk_args]``, in order, on ``workers`` processes.

    ``chunk_args`` holds what differs between chunks (their samples), ``shared`` the
    settings every chunk takes alike. ``workers`` = 1 runs in this process (no pool);
    None uses every available core. ``fn`` must be a module-level function (it is
    pickled to the workers).
    """
    workers = default_workers() if workers is None else int(workers)
    if workers < 1:
        raise ValueError(f"workers must be >= 1 (or None for all cores), got {workers}.")
    if workers == 1 or len(chunk_args) <= 1:
        return [fn(*args, **shared) for args in chunk_args]
    with ProcessPoolExecutor(max_workers=min(workers, len(chunk_args))) as pool:
        futures = [pool.submit(fn, *args, **shared) for args in chunk_args]
        return [f.result() for f in futures]

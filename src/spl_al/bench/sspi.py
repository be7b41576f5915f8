"""SSPI benchmark: ``python -m spl_al.bench sspi [--weights FOLDER] [--captures FOLDER]``.

Two tables, each with the maximum-likelihood methods beside SSPI:

1. Real photons: every ``*.mat`` capture of ``--captures`` (default
   ``$SPL_AL_REAL_CAPTURES``; the ugv45m frames: 64x64, 10,000 bins of 100 ps),
   reconstructed by ``sspi`` and ``pooled``; their depth agreement on the pixels
   both reconstruct (median |difference|, fraction within 10 cm / 30 cm) and the
   time per frame.
2. Simulated: the demo scene (``spl_al.photon.pictures.demo_scene``, 64x64, 4-10 m)
   at the weights' bin width (1024 bins of 80 ps, sigma 2 bins) over a grid of
   MSPPP x SBR; per method the fraction of all pixels within 10 cm of the truth
   (voids count as misses), the RMSE over reconstructed pixels, the void fraction
   and the time per frame.

Weights: ``--weights`` or ``$SPL_AL_SSPI_WEIGHTS`` (see ``spl_al.photon.sspi``).
SSPI runs single-threaded on CPU (CUDA when available); pin the process with
``taskset -c 0`` for one-core figures.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from spl_al.bench.timing import markdown_table
from spl_al.config import REAL_CAPTURES_ENV
from spl_al.photon import (
    Condition,
    PhotonScene,
    SensorParams,
    load_mat,
    reconstruct,
    simulate_photons,
)
from spl_al.photon.pictures import demo_scene, depth_agreement

MSPPP = (1.0, 2.0, 5.0, 10.0)
SBR = (0.05, 0.2, 1.0, 5.0)
METHODS = ("sspi", "pooled", "lmf")


def _timed(fn):
    """(fn(), wall seconds, CPU seconds of this process)."""
    start, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - start, time.process_time() - cpu


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _frame_cost_child(conn, events, sensor, weights, repeats):
    # torch on demand (importing this module does not load it)
    import resource

    from spl_al.photon.sspi.weights import load_sspi

    load_sspi(weights, "cpu")
    baseline = _rss_mb()
    walls, cpus = [], []
    for _ in range(repeats):
        _, wall, cpu = _timed(
            lambda: reconstruct(events, events.shape, sensor, method="sspi", weights=weights)
        )
        walls.append(wall)
        cpus.append(cpu)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux
    conn.send((float(np.median(walls)), float(np.median(cpus)), peak - baseline))


def sspi_frame_cost(events, sensor, weights=None, repeats: int = 3):
    """(median wall s, median CPU s, peak RSS growth MB) of SSPI on one frame, on CPU.

    Runs in a fresh process so the peak memory is this frame's: the high-water mark
    of the run minus the resident size once torch and the weights are loaded.
    """
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    parent, child = ctx.Pipe()
    proc = ctx.Process(target=_frame_cost_child, args=(child, events, sensor, weights, repeats))
    proc.start()
    result = parent.recv()
    proc.join()
    return result


def real_table(captures: Path, weights) -> str:
    """Markdown table of SSPI against pooled ML on each real ``.mat`` capture
    (voids, agreement, time)."""
    sensor = SensorParams.ugv45m()
    rows = []
    for path in sorted(captures.glob("*.mat")):
        events = load_mat(path)
        sspi, t_sspi, cpu_sspi = _timed(
            lambda ev=events: reconstruct(ev, ev.shape, sensor, method="sspi", weights=weights)
        )
        pooled, t_pooled, _ = _timed(
            lambda ev=events: reconstruct(ev, ev.shape, sensor, method="pooled")
        )
        a = depth_agreement(sspi.depth_m, pooled.depth_m)
        rows.append(
            [
                path.stem,
                f"{len(events):,}",
                f"{100 * np.mean(~sspi.valid):.1f}",
                f"{100 * np.mean(~pooled.valid):.1f}",
                f"{np.nanmedian(sspi.depth_m):.2f}",
                f"{100 * a['median_abs_m']:.1f}",
                f"{100 * a['within_10cm']:.1f}",
                f"{100 * a['within_30cm']:.1f}",
                f"{t_sspi:.2f} ({cpu_sspi:.2f})",
                f"{t_pooled * 1e3:.0f}",
            ]
        )
    header = [
        "capture",
        "photons",
        "sspi voids %",
        "pooled voids %",
        "sspi median depth m",
        "median abs diff cm",
        "within 10 cm %",
        "within 30 cm %",
        "sspi s (CPU s)",
        "pooled ms",
    ]
    return markdown_table(header, rows)


def simulated_table(weights, msppp=MSPPP, sbr=SBR, seed: int = 0) -> str:
    """Markdown table of SSPI against the ML methods on the simulated demo scene
    at each MSPPP (signal photons per pixel) and SBR."""
    sensor = SensorParams.tabletop()
    depth, refl = demo_scene(64, 64)
    rows = []
    for m in msppp:
        for s in sbr:
            rng = np.random.default_rng(seed)
            events = simulate_photons(
                PhotonScene(depth, reflectance=refl), Condition(m, s, sensor), rng
            )
            cells = [f"{m:g}", f"{s:g}", f"{len(events):,}"]
            for method in METHODS:
                rec, seconds, cpu = _timed(
                    lambda ev=events, method=method: reconstruct(
                        ev, depth.shape, sensor, method=method, weights=weights
                    )
                )
                err = np.abs(rec.depth_m - depth)
                within = np.mean(np.where(rec.valid, err, np.inf) <= 0.1)
                rmse = np.sqrt(np.nanmean(err**2)) if rec.valid.any() else np.nan
                cells += [
                    f"{100 * within:.1f}",
                    f"{100 * rmse:.0f}",
                    f"{100 * np.mean(~rec.valid):.1f}",
                    f"{seconds:.2f} s ({cpu:.2f})"
                    if method == "sspi"
                    else f"{seconds * 1e3:.0f} ms",
                ]
            rows.append(cells)
    header = ["MSPPP", "SBR", "photons"]
    for method in METHODS:
        header += [f"{method} <=10cm %", f"{method} RMSE cm", f"{method} voids %", f"{method} time"]
    return markdown_table(header, rows)


def main(argv: list[str]) -> int:
    """Compare SSPI with the ML reconstructions; print the tables; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench sspi")
    parser.add_argument("--weights", default=None, help="default $SPL_AL_SSPI_WEIGHTS")
    parser.add_argument("--captures", default=os.environ.get(REAL_CAPTURES_ENV))
    parser.add_argument("--msppp", type=float, nargs="+", default=list(MSPPP))
    parser.add_argument("--sbr", type=float, nargs="+", default=list(SBR))
    args = parser.parse_args(argv)

    # torch on demand (importing this module does not load it)
    from spl_al.photon.sspi.weights import load_sspi

    net = load_sspi(args.weights)  # fails early, saying where to get the weights
    print(
        f"SSPI on {net.device} ({platform.machine()}, {os.cpu_count()} cores visible); "
        "times are wall seconds of one run, CPU seconds of the process in brackets."
    )
    if args.captures and Path(args.captures).is_dir():
        print("\nReal captures (ugv45m: 64x64, 10,000 bins of 100 ps), sspi vs pooled:\n")
        print(real_table(Path(args.captures), args.weights))
    else:
        print("\nReal captures: skipped (no --captures / $SPL_AL_REAL_CAPTURES folder).")
    print(
        "\nSimulated demo scene (64x64, 4-10 m, 1024 bins of 80 ps, sigma 2 bins, seed 0); "
        "<=10cm % over all pixels (voids are misses), RMSE over reconstructed pixels:\n"
    )
    print(simulated_table(args.weights, args.msppp, args.sbr))
    return 0

"""Photon engine benchmark: ``python -m spl_al.bench photon [--repeats N]``.

For a 64x64 frame with 1024 bins of 80 ps at three conditions, prints the median
time to simulate and to reconstruct (each method), the photons per second of the
simulator, and its speedup over the literal loop transcription of Algorithm 1.
Run it on one core (the numpy work here is single-threaded anyway).

With SSPI weights (``--sspi-weights`` or ``$SPL_AL_SSPI_WEIGHTS``) a second table
gives SSPI per frame: median wall and CPU seconds of 3 runs and the peak memory,
each condition in a fresh process (``spl_al.bench.sspi.sspi_frame_cost``).
"""

from __future__ import annotations

import argparse
import os
import platform
from functools import partial

import numpy as np

from spl_al.bench.sspi import sspi_frame_cost
from spl_al.bench.timing import markdown_table, median_seconds
from spl_al.config import SSPI_WEIGHTS_ENV
from spl_al.photon import Condition, PhotonScene, SensorParams, reconstruct, simulate_photons
from spl_al.photon.pictures import demo_scene
from spl_al.photon.reference import simulate_photons_loop

CONDITIONS = ((2.0, 0.2), (5.0, 1.0), (10.0, 5.0))


def main(argv: list[str]) -> int:
    """Time simulation and every reconstruction method; print the table; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench photon")
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--sspi-weights", default=os.environ.get(SSPI_WEIGHTS_ENV))
    args = parser.parse_args(argv)

    sensor = SensorParams.tabletop()
    depth, refl = demo_scene(64, 64)
    rows = []
    for msppp, sbr in CONDITIONS:
        rng = np.random.default_rng(0)
        args_sim = (PhotonScene(depth, refl), Condition(msppp, sbr, sensor), rng)
        events = simulate_photons(*args_sim)
        t_sim = median_seconds(partial(simulate_photons, *args_sim), args.repeats)
        t_loop = median_seconds(partial(simulate_photons_loop, *args_sim), repeats=3, warmup=0)
        t_rec = {
            m: median_seconds(
                partial(reconstruct, events, depth.shape, sensor, method=m), args.repeats
            )
            for m in ("lmf", "pooled")
        }
        rows.append(
            [
                f"{msppp:g}",
                f"{sbr:g}",
                f"{len(events):,}",
                f"{t_sim * 1e3:.2f}",
                f"{len(events) / t_sim / 1e6:.1f}",
                f"{t_loop * 1e3:.0f}",
                f"{t_loop / t_sim:.0f}x",
                f"{t_rec['lmf'] * 1e3:.1f}",
                f"{t_rec['pooled'] * 1e3:.1f}",
            ]
        )
    print(
        f"Photon engine, 64x64 frame, {sensor.n_bins} bins of {sensor.bin_width_s * 1e12:.0f} ps, "
        f"sigma {sensor.sigma_bins:g} bins; median of {args.repeats} runs on {platform.machine()}"
    )
    print()
    print(
        markdown_table(
            [
                "MSPPP",
                "SBR",
                "photons",
                "simulate ms",
                "Mphotons/s",
                "loop ref. ms",
                "speedup",
                "lmf ms",
                "pooled ms",
            ],
            rows,
        )
    )
    if args.sspi_weights:
        print()
        print(sspi_rows(sensor, depth, refl, args.sspi_weights))
    else:
        print("\nSSPI: skipped (no --sspi-weights / $SPL_AL_SSPI_WEIGHTS).")
    return 0


def sspi_rows(sensor, depth, refl, weights) -> str:
    """SSPI per 64x64x1024 frame at CONDITIONS: wall / CPU seconds and peak memory."""
    rows = []
    for msppp, sbr in CONDITIONS:
        events = simulate_photons(
            PhotonScene(depth, reflectance=refl),
            Condition(msppp, sbr, sensor),
            np.random.default_rng(0),
        )
        wall, cpu, peak_mb = sspi_frame_cost(events, sensor, weights)
        target = "yes" if cpu <= 2.0 else "no"  # CPU time: the wall time of a loaded machine lies
        rows.append(
            [
                f"{msppp:g}",
                f"{sbr:g}",
                f"{len(events):,}",
                f"{wall:.2f}",
                f"{cpu:.2f}",
                f"{peak_mb:.0f}",
                target,
            ]
        )
    header = ["MSPPP", "SBR", "photons", "sspi wall s", "sspi CPU s", "peak MB", "CPU <= 2 s"]
    return "SSPI (single-threaded, CPU), median of 3 runs:\n\n" + markdown_table(header, rows)

"""Capture import benchmark: ``python -m spl_al.bench captures [--repeats N]``.

One simulated 64x64 frame (a wall at ~60 m with a car at 52 m, MSPPP 5, SBR 1, 520 ps
jitter) written in every format ``load_capture`` reads, and for each: file size,
photons, the median time to load it, to estimate the pulse sigma and the frame's
conditions, and to reconstruct it into the release layout (``reconstruct_capture``,
pooled). The timestamp file holds picosecond times at 4 ps resolution (150,000 bins
in a 600 ns gate), the others 80 ps bins. With ``$SPL_AL_REAL_CAPTURES`` (the ugv45m
folder) a row per real frame follows.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
from functools import partial
from pathlib import Path

import numpy as np

from spl_al.bench.timing import markdown_table, median_seconds
from spl_al.config import REAL_CAPTURES_ENV
from spl_al.photon import Condition, PhotonScene, SensorParams, simulate_photons
from spl_al.photon.calibration import estimate_conditions, estimate_pulse_sigma
from spl_al.photon.formats import writers
from spl_al.photon.io import load_capture
from spl_al.photon.release import reconstruct_capture

COARSE = SensorParams(bin_width_s=80e-12, pulse_sigma_s=520e-12, n_bins=1024)
FINE = SensorParams(bin_width_s=4e-12, pulse_sigma_s=520e-12, n_bins=150_000)
GATE_START_S = 330e-9  # bins start 49.5 m out, so the coarse gate (12.3 m) holds the scene


def _events(sensor: SensorParams, gate_start_s: float):
    rows, cols = 64, 64
    yy, xx = np.mgrid[:rows, :cols]
    depth = 60.0 + 0.02 * xx
    depth[(yy > 36) & (xx > 12) & (xx < 44)] = 52.0
    depth -= 299_792_458.0 * gate_start_s / 2  # depth within the gate
    return simulate_photons(
        PhotonScene(depth), Condition(5.0, 1.0, sensor), np.random.default_rng(0)
    )


def _write_all(folder: Path) -> dict[str, Path]:
    coarse = _events(COARSE, GATE_START_S)
    fine = _events(FINE, 0.0)
    return {
        "sparse_mat": writers.write_sparse_mat(folder / "sparse.mat", coarse, COARSE),
        "timestamps_mat (4 ps)": writers.write_timestamps_mat(
            folder / "ts.mat", fine, bin_width_ps=4
        ),
        "cube .npz": writers.write_cube_npz(folder / "cube.npz", coarse, COARSE),
        "cube HDF5": writers.write_cube_h5(folder / "cube.h5", coarse, COARSE),
        "ptu": writers.write_ptu(folder / "scan.ptu", coarse, COARSE),
    }


def _row(name: str, path: Path, repeats: int) -> list[str]:
    load = partial(load_capture, path)
    capture = load()
    t_load = median_seconds(load, repeats)
    slow = min(repeats, 3)  # the estimates and the reconstruction take ~0.1-0.3 s each
    t_sigma = median_seconds(partial(estimate_pulse_sigma, capture.events, capture.n_bins), slow)
    t_cond = median_seconds(partial(estimate_conditions, capture.events, capture.n_bins), slow)
    t_rec = median_seconds(partial(reconstruct_capture, capture), slow, warmup=0)
    result = reconstruct_capture(capture)
    return [
        name,
        f"{path.stat().st_size / 1e6:.2f}",
        f"{len(capture.events):,}",
        f"{capture.n_bins:,}",
        f"{t_load * 1e3:.0f}",
        f"{t_sigma * 1e3:.0f}",
        f"{t_cond * 1e3:.0f}",
        f"{t_rec * 1e3:.0f}",
        f"{result.pulse_sigma_s * 1e12:.0f}",
        f"{result.msppp:.2f}",
        f"{result.sbr:.2f}",
    ]


def main(argv: list[str]) -> int:
    """Time every format's import and reconstruction; print the table; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench captures")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        rows = [_row(n, p, args.repeats) for n, p in _write_all(Path(tmp)).items()]
    real = os.environ.get(REAL_CAPTURES_ENV)
    if real:
        for path in sorted(Path(real).glob("*.mat")):
            rows.append(_row(f"ugv45m {path.stem}", path, args.repeats))
    print(
        "Capture import, 64x64 frames (simulated: MSPPP 5 over the frame, SBR 1, 520 ps "
        f"jitter); median wall ms on {platform.machine()}; sigma / MSPPP / SBR as estimated"
    )
    print()
    header = ["format", "MB", "photons", "bins", "load ms", "sigma ms", "conditions ms"]
    header += ["reconstruct ms", "sigma ps", "MSPPP", "SBR"]
    print(markdown_table(header, rows))
    return 0

"""``spl_al.query`` with DUIS: time inside the user's ``predict`` against time outside it.

``python -m spl_al.bench query [--frames N] [--budget B] [--seed S] [--jobs J]``

A pool of N 64x64 frames (procedural object scenes, ``spl_al.scenes``: depth with
voids where nothing returns, uniform reflectance as a user without one would pass),
``spl_al.models``' SmallCNN (untrained; 11 classes) as ``predict`` (its probabilities
and penultimate features, fp32 on the CPU), and DUIS (M = 4 variants per frame at the
default conditions, N_cand as ``spl_al.query`` chooses it) queried twice:

1. the first query of a pool: ``query`` makes the variants itself, in J processes;
2. a later round's query: the pool's variants made once (``make_variants``, timed on
   its own) and given to it (``variants=``), as every round after the first can.

Each table splits the query's wall time: ``predict`` (the model's forward passes over
every frame and its variants), the variants (photon simulation and reconstruction,
``spl_al.photon.synthesize_variants``), the strategy's selection (k-means, nearest
frames, UIS ranking) and the rest (reductions to DUIS's scores, stacking), with the
share of the whole spent outside ``predict``. The last table splits the variants of
the first frames by condition: photons, simulation and reconstruction per frame.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from spl_al.acquire import Request, default_conditions, make_variants, run
from spl_al.bench.estimate import cpu_name
from spl_al.bench.timing import markdown_table
from spl_al.photon import Condition, PhotonScene, SensorParams, reconstruct, simulate_photons
from spl_al.photon.siv import photon_window
from spl_al.scenes.objects import CATEGORIES, render_object

SHAPE = (64, 64)


def pool(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` frames of the 11 object categories in turn: depth (n, 64, 64) float32 with
    NaN where nothing returns, and the valid mask."""
    rng = np.random.default_rng(seed)
    depth = np.stack(
        [render_object(CATEGORIES[i % len(CATEGORIES)], rng, SHAPE).depth_m for i in range(n)]
    ).astype(np.float32)
    return depth, np.isfinite(depth)


def smallcnn_predict(n_classes: int = 11):
    """SmallCNN (untrained, seeded) as a ``predict`` function: (probabilities, features)."""
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.models import build_model
    from spl_al.training.compute import Compute
    from spl_al.training.forward import predict as forward

    torch.manual_seed(0)
    model = build_model("classification", n_classes, arch="smallcnn").eval()

    def predict(depth_m, valid):
        out = forward(model, depth_m, valid, compute=Compute("cpu"), batch_size=len(depth_m))
        return out.probs, out.features

    return predict


def variant_costs(depth, valid, n_frames: int, sensor: SensorParams) -> list[list]:
    """Rows per condition: photons, simulate ms and reconstruct ms per frame (mean over
    the first ``n_frames`` frames, each on its returns' bounding box)."""
    rows = []
    rng = np.random.default_rng(0)
    for msppp, sbr in default_conditions(4):
        photons, t_sim, t_rec = 0, 0.0, 0.0
        for i in range(n_frames):
            rows_, cols_ = photon_window(valid[i])
            v = valid[i, rows_, cols_]
            scene = PhotonScene(np.where(v, depth[i, rows_, cols_], 0.0), None, v)
            start = time.perf_counter()
            events = simulate_photons(scene, Condition(msppp, sbr, sensor), rng)
            mid = time.perf_counter()
            reconstruct(events, events.shape, sensor)
            t_sim += mid - start
            t_rec += time.perf_counter() - mid
            photons += len(events)
        rows.append(
            [
                f"{msppp:g}",
                f"{sbr:g}",
                f"{photons / n_frames:,.0f}",
                f"{1e3 * t_sim / n_frames:.1f}",
                f"{1e3 * t_rec / n_frames:.1f}",
            ]
        )
    return rows


def print_split(title: str, selection, n_frames: int, n_labeled: int) -> None:
    """A table of the query's wall time by part, and the share outside predict."""
    s = selection.seconds
    outside = s["total"] - s["predict"]
    other = outside - s["variants"] - s["select"]
    unlabeled = n_frames - n_labeled
    print(f"### {title}\n\n{selection.frames_predicted} images through predict.\n")
    header = ["part", "seconds", "ms per pool frame", "share of the whole"]
    parts = [
        ("predict (SmallCNN, frames and variants)", s["predict"]),
        ("variants (photon simulation + reconstruction)", s["variants"]),
        ("selection (k-means, nearest frames, UIS)", s["select"]),
        ("the rest (scores, stacking)", other),
        ("**outside predict**", outside),
        ("**whole query**", s["total"]),
    ]
    rows = [
        [name, f"{sec:.1f}", f"{1e3 * sec / unlabeled:.1f}", f"{sec / s['total']:.0%}"]
        for name, sec in parts
    ]
    print(markdown_table(header, rows))
    print(
        f"\nOverhead (outside predict) {outside / s['total']:.0%} of the whole "
        "(goal: at most 25%).\n"
    )


def main(argv: list[str]) -> int:
    """Time DUIS's first and later queries over a pool; print the tables; the exit code."""
    # torch on demand (importing this module does not load it)
    import torch

    parser = argparse.ArgumentParser(prog="python -m spl_al.bench query", description=__doc__)
    parser.add_argument("--frames", type=int, default=1000, help="frames in the pool (N)")
    parser.add_argument("--budget", type=int, default=20, help="frames to pick")
    parser.add_argument("--labeled", type=int, default=20, help="frames labeled already")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--batch-size", type=int, default=256, help="frames per predict call")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="variant processes")
    parser.add_argument("--profile-frames", type=int, default=50, help="frames of the last table")
    args = parser.parse_args(argv)
    if args.frames <= args.labeled + args.budget:
        parser.error("--frames must exceed --labeled + --budget")
    depth, valid = pool(args.frames, args.seed)
    predict = smallcnn_predict()
    predict(depth[:8], valid[:8])  # warm-up: torch's first call
    print(
        f"## spl_al.query, DUIS (M = 4), {args.frames} frames of 64x64 "
        f"({args.frames - args.labeled} unlabeled), SmallCNN as predict\n\n"
        f"{cpu_name()}, {os.cpu_count()} cores, torch {torch.get_num_threads()} threads, "
        f"variants in {args.jobs} processes, {time.strftime('%Y-%m-%d')}; valid pixels "
        f"{valid.mean():.0%}.\n"
    )
    kw = {"labeled": np.arange(args.labeled), "budget": args.budget, "seed": args.seed}
    kw |= {"batch_size": args.batch_size, "n_jobs": args.jobs}
    first = run(Request("duis", predict, depth, valid, **kw))
    print_split("The first query (variants made by the query)", first, args.frames, args.labeled)
    start = time.perf_counter()
    variants = make_variants(depth, valid, seed=args.seed, n_jobs=args.jobs)
    made = time.perf_counter() - start
    later = run(Request("duis", predict, depth, valid, variants=variants, **kw))
    assert np.array_equal(later.indices, first.indices), "kept variants changed the picks"
    print(
        f"Making the pool's variants once (`make_variants`, {args.jobs} processes): "
        f"{made:.1f} s, {1e3 * made / args.frames:.1f} ms a frame.\n"
    )
    print_split("A later round (the variants made once, given)", later, args.frames, args.labeled)
    print(f"Load average at the end: {os.getloadavg()[0]:.2f}.\n")
    n = min(args.profile_frames, args.frames)
    sensor = SensorParams.paper_real()
    print(f"Variants by condition, mean over the first {n} frames (paper_real sensor):\n")
    header = ["MSPPP", "SBR", "photons per frame", "simulate ms", "reconstruct ms"]
    print(markdown_table(header, variant_costs(depth, valid, n, sensor)))
    return 0

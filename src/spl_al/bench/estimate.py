"""Predicted wall time of a config's run on this machine: ``python -m spl_al.bench estimate``.

Run it before a long run (``--configfile`` as for Snakemake; default: the default
config). For every dataset it times, on the CPU (or GPU) at hand:

- its model: a few training steps of the dataset's own recipe at the precision
  ``precision: auto`` resolves to here, and a few forward passes
  (``spl_al.bench.training.measure``, ``threads_per_job`` threads);
- its data: a miniature of the dataset synthesised and given its M variants
  (a few images; the photon simulation and reconstruction cost per pixel).

and multiplies by what the config plans (``spl_al.experiment.plan``): every training's
optimiser steps (``TrainConfig.total_steps`` at the groups labeled in that round),
the forward passes of evaluation (the test split every round) and scoring (the
unlabeled pool before every query, with the variants for DUIS's group scores), the
data (observed images, variants, the robustness grid), and a start-up cost per job.
The jobs run ``-j`` at a time (``--jobs``, default 2), so the wall time is the core
time over the jobs in parallel.

It prints a line per dataset and a total, with the CPU model, threads and precision
assumed. A prediction, not a measurement: docs/benchmarks.md compares it with runs.
"""

from __future__ import annotations

import argparse
import copy
import os
import platform
import time
from pathlib import Path

from spl_al.bench.projection import merged_config, method_variants, model_case, split_sizes
from spl_al.bench.timing import markdown_table
from spl_al.bench.training import measure
from spl_al.blas_threads import one_thread
from spl_al.config import dataset_precision
from spl_al.data import Dataset
from spl_al.data.sources import is_synthesised
from spl_al.data.variants import generate_variants
from spl_al.experiment import dense_embedding
from spl_al.experiment.data_steps import make_dataset
from spl_al.experiment.encoders import encoder_recipe, encoder_seeds
from spl_al.experiment.plan import dataset_method, dataset_runs, labeled_at
from spl_al.experiment.shared_embedding import SHARED
from spl_al.frameworks import EMBEDDING
from spl_al.linear_probe import LinearProbe, dropout_head, probe_inputs
from spl_al.multinomial import loss_gradient, make_problem
from spl_al.pool import Pool
from spl_al.strategies import GROUP_NEEDS, get
from spl_al.strategies import get as get_strategy
from spl_al.training import TrainConfig

ROOT = Path(__file__).resolve().parents[3]

# Start-up of one job: a fork of the warm job process, else a new interpreter that
# imports torch (docs/benchmarks.md#pipeline: 0.21 s and ~2 s per job).
JOB_START_S = {True: 0.21, False: 2.0}
# The Snakemake process's own time per job (scheduling, file checks), on the cores the
# jobs use (docs/benchmarks.md#estimate: fitted to measured runs).
SCHEDULER_S_PER_JOB = 0.3
# Report jobs (tables, curves, stats, summary) per dataset, and the fixed ones of a run.
REPORT_JOBS, FIXED_JOBS = 9, 2
# Paired statistics of an embedding framework's report, per (method, seed) run: 30 s
# for real_cls's 2,100 runs and 25 s for synth_cls's 1,800 (2-core Zen 5, 2026-11-27).
REPORT_S_PER_RUN = 0.014
MINI_IMAGES = {"classification": 2, "segmentation": 6}  # per class / in all
STEPS = 30  # timed training steps per model, for the command line and the plan alike


def cpu_name() -> str:
    """The CPU model as lscpu names it (or the platform's word for it)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def plan_counts(config: dict, dataset: str) -> dict:
    """What a dataset's experiments run: trainings and their images, forward-pass images
    (evaluation, scoring), queries and round-0 copies (jobs without training)."""
    # pandas on demand (importing this module does not load it)
    from spl_al.experiment.plan import dataset_method, dataset_runs, labeled_at, start_of

    entry = config["datasets"][dataset]
    n_pool, n_test, _ = split_sizes(entry)
    fit = {k: v for k, v in entry["train"]["fit"].items() if v is not None}
    cfg = TrainConfig.from_dict(fit)
    # Rounds >= 1 fine-tune the previous round's weights with the warm-start fields.
    warm = entry["train"].get("warm_start")
    warm_cfg = TrainConfig.from_dict({**fit, **warm}) if warm else cfg
    counts = {"trainings": 0, "train_images": 0, "forward_images": 0, "queries": 0, "copies": 0}
    initial = set()
    for (method, seed), rounds in dataset_runs(config, dataset).items():
        m = method_variants(config, dataset, method)
        start = start_of(config, dataset, method)  # a cold-start arm has its own round 0
        spec = dataset_method(config, dataset, method)
        needs = get_strategy(spec.strategy, **spec.params).needs
        scored = 1 + int(config["datasets"][dataset]["variants"]["n"]) if needs & GROUP_NEEDS else 1
        counts["queries"] += rounds - 1
        for r in range(rounds):
            groups = labeled_at(entry["al"], r)
            if r + 1 < rounds:  # the pool is scored for the next query
                counts["forward_images"] += (n_pool - groups) * scored
            if r == 0:
                counts["copies"] += 1
                if (seed, m, start) in initial:
                    continue  # one round-0 fit per seed, variants per group and start
                initial.add((seed, m, start))
            n = groups * (1 + m)
            counts["trainings"] += 1
            c = warm_cfg if r > 0 else cfg
            counts["train_images"] += c.total_steps(n, groups) * min(c.batch_size, n)
            counts["forward_images"] += n_test
    return counts


def _mini_entry(entry: dict) -> tuple[dict, int]:
    """A few images of the dataset's own kind (same shape, scenes and sensor), and
    how many."""
    mini = copy.deepcopy(entry)
    syn = mini.setdefault("synthesis", {})
    syn["workers"] = 1
    if entry["task"] == "classification":
        syn["n_per_class"] = MINI_IMAGES["classification"]
        return mini, MINI_IMAGES["classification"] * 11
    syn["n_samples"] = MINI_IMAGES["segmentation"]
    return mini, MINI_IMAGES["segmentation"]


def data_seconds_per_image(entry: dict, tmp: Path) -> tuple[float, float]:
    """(observed image, one variant) seconds per image, timed on a miniature."""
    mini, n = _mini_entry(entry)
    mini["source"] = "synthetic"  # a stand-in is synthesised as a procedural set is
    start = time.perf_counter()
    make_dataset(mini, tmp / "mini.npz")
    observed = (time.perf_counter() - start) / n
    m = int(entry["variants"]["n"])
    dataset = Dataset.load(tmp / "mini.npz")
    start = time.perf_counter()
    generate_variants(dataset, n_variants=m, seed=0, workers=1)
    return observed, (time.perf_counter() - start) / (n * m)


def robustness_images(config: dict, dataset: str) -> int:
    """Test images the robustness map simulates (0 when it is off for the dataset)."""
    entry = config["datasets"][dataset]
    grid = {**(config.get("robustness") or {}), **(entry.get("robustness") or {})}
    if not grid.get("enabled", True) or "budget" not in entry.get("experiments", {}):
        return 0
    _, n_test, _ = split_sizes(entry)
    n = min(int(grid.get("test_samples") or n_test), n_test)
    return n * len(grid.get("msppp", [])) * len(grid.get("sbr", []))


def _measure(case) -> tuple[float, float]:
    # torch on demand (importing this module does not load it)
    from spl_al.training.precision import MEASURE_PRECISION

    task, model_cfg, fit, shape, precision, threads, steps, device = case
    return measure(
        task,
        model_cfg,
        fit,
        shape=shape,
        precision=precision,
        threads=threads,
        steps=steps,
        device=device,
        infer_precision=MEASURE_PRECISION,  # scoring and evaluation: fp32 whatever trains
    )


def concurrent_rates(case, jobs: int) -> tuple[float, float]:
    """(train, inference) images/s of one job while ``jobs`` jobs train at once, as
    ``snakemake -j`` runs them: two trainings on two cores share the memory bandwidth
    and caches, and each runs ~20% slower than alone (docs/benchmarks.md#estimate)."""
    if jobs <= 1:
        return _measure(case)
    import multiprocessing

    # spawn, not fork: the caller may be a threaded process (Snakemake's, for the plan)
    with multiprocessing.get_context("spawn").Pool(jobs) as pool:
        rates = pool.map(_measure, [case] * jobs)
    return min(r[0] for r in rates), min(r[1] for r in rates)


def deploy_jobs(config: dict, dataset: str) -> int:
    """Model cards beside the budget's final models and the ONNX exports (seconds each)."""
    # pandas on demand (importing this module does not load it)
    from spl_al.experiment.plan import experiments_of

    budget = experiments_of(config, dataset).get("budget")
    if not budget:
        return 0
    exported = set((config.get("export") or {}).get("methods", [])) & set(budget["methods"])
    arch = config["datasets"][dataset]["train"].get("model", {}).get("arch")
    exports = 0 if arch == "pointnet2" else len(exported)
    return (len(budget["methods"]) + exports) * len(budget["seeds"])


def estimate_dataset(config: dict, dataset: str, *, tmp: Path, steps: int, jobs: int = 2) -> dict:
    """Seconds of one dataset's jobs, by part, and its job count."""
    # torch on demand (importing this module does not load it)
    import torch

    from spl_al.models import model_class
    from spl_al.training import resolve_device
    from spl_al.training.precision import resolve_precision

    entry = config["datasets"][dataset]
    task, _, model_cfg, fit, shape, _ = model_case(config, dataset)
    device = resolve_device(config.get("device", "auto"))
    precision = resolve_precision(
        dataset_precision(config, dataset), device, model_class(task, model_cfg.get("arch"))
    )
    threads = int(config.get("threads_per_job", 1))
    torch.set_num_threads(threads)
    case = (task, model_cfg, fit, shape, precision, threads, steps, str(device))
    train_rate, infer_rate = concurrent_rates(case, jobs if device.type == "cpu" else 1)
    counts = plan_counts(config, dataset)
    observed_s, variant_s = data_seconds_per_image(entry, tmp)
    n_pool, n_test, _ = split_sizes(entry)
    n_images, m = n_pool + n_test, int(entry["variants"]["n"])
    robust = robustness_images(config, dataset)
    jobs = (
        counts["trainings"] + counts["queries"] + counts["copies"] + REPORT_JOBS
        + 2 + 2 * int(entry["variants"].get("shards", 1)) + (2 if robust else 0)
        + deploy_jobs(config, dataset)
    )  # fmt: skip
    return {
        "precision": precision,
        "train_rate": train_rate,
        "train_s": counts["train_images"] / train_rate,
        "forward_s": counts["forward_images"] / infer_rate,
        # the robustness grid re-observes the test images as the observed ones were made
        "data_s": (n_images + robust) * observed_s + n_images * m * variant_s,
        "jobs": jobs,
        "trainings": counts["trainings"],
    }


def probe_round_seconds(
    spec, *, n_pool: int, n_test: int, m: int, dim: int, n_labeled: int, repeats: int = 3
) -> float:
    """Seconds of one embedding-framework round of the method ``spec`` (a ``MethodSpec``):
    fit the linear probe on its images, measure the test split, score and query the
    pool, timed ``repeats`` times on random embeddings of the pool's size (the first
    run, imports and warm-up, not counted)."""
    import numpy as np

    m = int(m)
    rng = np.random.default_rng(0)
    emb = rng.normal(size=(n_pool, 1 + m, dim)).astype(np.float32)
    labels = rng.integers(0, 11, n_pool)
    labeled = np.arange(n_labeled)
    unlabeled = np.arange(labeled.size, n_pool)
    g = 1 + spec.variants_seen(m)
    strategy = get(spec.strategy, **_fitting_params(spec, unlabeled.size))
    with one_thread():
        for i in range(1 + repeats):
            if i == 1:
                started = time.perf_counter()
            x_fit = emb[labeled, :g].reshape(-1, emb.shape[-1])
            y_fit = np.repeat(labels[labeled], g)
            probe = LinearProbe(11).fit(x_fit, y_fit)
            probe.predict_proba(emb[:n_test, 0])
            head = None
            if "head" in strategy.needs:  # DropQuery's own head, as a run fits it
                head = dropout_head(x_fit, y_fit, 11, np.random.default_rng(i)).head()
            inputs = probe_inputs(
                probe, emb, strategy.needs, unlabeled_idx=unlabeled, labeled_idx=labeled,
                n_images=g, head=head,
            )  # fmt: skip
            strategy.select(inputs, 20, np.random.default_rng(i))
    return (time.perf_counter() - started) / repeats


def first_batch_seconds(start: str, *, n_pool: int, dim: int, size: int, repeats: int = 2):
    """Seconds of one cold-start first batch (``spl_al.cold_start.first_batch``) of
    ``size`` from ``n_pool`` random embeddings, the first run not counted."""
    # the strategies on demand (importing this module does not load them)
    import numpy as np

    from spl_al.cold_start import first_batch

    emb = np.random.default_rng(0).normal(size=(n_pool, dim)).astype(np.float32)
    for i in range(1 + repeats):
        if i == 1:
            started = time.perf_counter()
        first_batch(emb, size, seed=i, strategy=start, n_classes=11)
    return (time.perf_counter() - started) / repeats


# Share of a street scan's pixels that are valid and labeled (the test pixels a dense
# probe measures): 73% of street_seg's.
DENSE_TEST_SHARE = 0.73
# L-BFGS iterations of a dense probe's fit on an encoder's features: 63-98 over 10
# fits of street_seg's at 6-36 scans from scratch, 69 a fit over a DUIS run's 15
# warm-started ones. On random features it stops after a few, so the estimate times
# its fit at this many, each at ``_gradient_seconds`` (a round timed at its own count
# read 0.4x the run's).
DENSE_FIT_ITERATIONS = 70


def _encoder_step_times(entry: dict, steps: int) -> tuple[float, float]:
    """(seconds a step, fixed seconds of a training) of the dataset's encoder recipe:
    the difference of a 1-step and a (1 + ``steps``)-step training on random frames of
    the training pool's size (so that the views index a pool as large as the run's)."""
    # torch on demand (importing this module does not load it)
    from dataclasses import replace

    import numpy as np

    from spl_al.training import contrastive as frames
    from spl_al.training import dense_contrastive as pixels

    dense = entry["task"] == "segmentation"
    config, train = (
        (pixels.DenseEncoderConfig, pixels.train_dense_encoder)
        if dense
        else (frames.EncoderConfig, frames.train_encoder)
    )
    cfg = config.from_dict(encoder_recipe(entry))
    n_pool, _, _ = split_sizes(entry)
    m = int(entry["variants"]["n"])
    shape = tuple((entry.get("synthesis") or {}).get("image_shape") or (64, 64))
    depth = np.random.default_rng(0).uniform(5, 50, size=(n_pool, 1 + m, *shape))
    depth = depth.astype(np.float32)
    valid = np.ones(depth.shape, dtype=bool)
    seconds = [
        train(depth, valid, cfg=replace(cfg, steps=k), log=os.devnull)[1]["train_seconds"]
        for k in (1, 1 + steps)
    ]
    step_s = max(seconds[1] - seconds[0], 0.0) / steps
    return step_s, max(seconds[0] - step_s, 0.0)


def encoder_seconds(entry: dict, *, steps: int, threads: int = 1) -> float:
    """Core seconds of one encoder job of the dataset's recipe, timed at the job's
    ``threads`` torch threads (restored after): its steps at the per-step time of
    ``steps`` timed steps (``_encoder_step_times``), its fixed cost, loading the
    dataset, and embedding every image (a dense encoder: its features and the local
    depth features of every pixel). Timed at torch's default of one thread per core, a
    street encoder read 118 s a job on a 2-core Xeon where its ``-j2`` run's took
    215-249 s at one thread (two such jobs at once: 0.65 s a step each, one alone 0.68)."""
    # torch on demand (importing this module does not load it)
    import numpy as np
    import torch

    from spl_al.dense_probe import local_depth_features
    from spl_al.training import contrastive as frames
    from spl_al.training import dense_contrastive as pixels

    before = torch.get_num_threads()
    torch.set_num_threads(int(threads))
    try:
        step_s, fixed_s = _encoder_step_times(entry, steps)
        dense = entry["task"] == "segmentation"
        config = pixels.DenseEncoderConfig if dense else frames.EncoderConfig
        cfg = config.from_dict(encoder_recipe(entry))
        shape = tuple((entry.get("synthesis") or {}).get("image_shape") or (64, 64))
        encoder = (pixels.DenseEncoder if dense else frames.Encoder)(cfg).eval()
        x = torch.randn(64 if dense else 512, 2, *shape)
        depth = np.random.default_rng(0).uniform(5, 50, size=(64, *shape)).astype(np.float32)
        with torch.no_grad():
            started = time.perf_counter()
            encoder(x)
            if dense:
                local_depth_features(depth, np.ones(depth.shape, dtype=bool))
            image_s = (time.perf_counter() - started) / len(x)
    finally:
        torch.set_num_threads(before)
    n_pool, n_test, _ = split_sizes(entry)
    m = int(entry["variants"]["n"])
    # the job also reads the dataset: ~75 ns a pixel of every image (the Zen 3 EPYC's:
    # 1.7 s for real_cls's 1,100 x 5 images of 64 x 64)
    load_s = 7.5e-8 * (n_pool + n_test) * (1 + m) * shape[0] * shape[1]
    return fixed_s + cfg.steps * step_s + load_s + (n_pool * (1 + m) + n_test) * image_s


def dense_round_seconds(
    spec, *, n_pool: int, n_test: int, m: int, dim: int, n_labeled: int, repeats: int = 3
) -> float:
    """``probe_round_seconds`` of a segmentation dataset: the dense probe's round
    (``spl_al.experiment.dense_embedding``) on random features of the pool's units, ``n_test``
    test pixels, 7 classes."""
    import numpy as np

    rng = np.random.default_rng(0)
    units = dense_embedding.UNITS_PER_SCAN
    facts = dense_embedding.DenseProbeData(
        train=rng.normal(size=(n_pool, 1 + int(m), units, dim)).astype(np.float32),
        train_valid=np.ones((n_pool, 1 + int(m), units), dtype=bool),
        unit_labels=rng.integers(0, 7, (n_pool, units)),
        test=rng.normal(size=(n_test, dim)).astype(np.float32),
        test_labels=rng.integers(0, 7, n_test),
        test_levels=np.full(n_test, "high"),
        classes=tuple("abcdefg"),
        n_total=n_pool,
        standin=True,
    )
    pool = Pool(n_pool, np.arange(n_labeled))
    g = 1 + spec.variants_seen(int(m))
    strategy = get(spec.strategy, **_fitting_params(spec, n_pool - n_labeled))
    stretch = 0.0  # the fit's time had it taken a real fit's iterations
    with one_thread():
        for i in range(1 + repeats):
            if i == 1:
                started, stretch = time.perf_counter(), 0.0
            fit_rng = np.random.default_rng(i)
            probe, x, y = dense_embedding.fit_probe(
                facts, pool.labeled_idx, g, probe={}, rng=fit_rng
            )
            if i == 0:  # untimed, as the warm-up round
                n_fit = min(len(y), dense_embedding.FIT_UNITS)
                iteration_s = _gradient_seconds(n_fit, x.shape[1], 7)
            stretch += max(DENSE_FIT_ITERATIONS - probe.iterations, 0) * iteration_s
            dense_embedding.test_miou(facts, probe)
            head = dropout_head(x, y, 7, fit_rng).head() if "head" in strategy.needs else None
            inputs = dense_embedding.query_inputs(
                facts, probe, strategy.needs, pool, n_images=g, head=head
            )
            strategy.select(inputs, 6, np.random.default_rng(i))
    return (time.perf_counter() - started + stretch) / repeats


def _gradient_seconds(n: int, d: int, k: int, repeats: int = 5) -> float:
    """Seconds of one loss-and-gradient evaluation of the dense probe's solver
    (``spl_al.multinomial``) on n x d features and k classes, an L-BFGS iteration's
    work."""
    import numpy as np

    rng = np.random.default_rng(0)
    problem = make_problem(rng.normal(size=(n, d)), np.arange(n) % k, rng.random(n), c=1.0)
    coef = (rng.normal(size=(k, d + 1)) * 0.1).ravel(order="F")
    started = time.perf_counter()
    for _ in range(repeats):
        loss_gradient(coef, problem)
    return (time.perf_counter() - started) / repeats


def _fitting_params(spec, n_unlabeled: int) -> dict:
    """The method's parameters with N_cand kept under half the unlabeled pool (the pool
    here may be smaller than the run's: keep the rule)."""
    params = dict(spec.params)
    if "n_cand" in params:
        params["n_cand"] = max(2, min(int(params["n_cand"]), n_unlabeled // 2))
    return params


def embedding_seconds(config: dict, dataset: str, *, steps: int = 10) -> dict:
    """Core seconds of a dataset's embedding framework (none without one) and its job
    count.

    - Each encoder job: ``encoder_seconds``, at the job's threads.
    - The probe runs: each planned method's rounds at its own timed round
      (``probe_round_seconds``, ``dense_round_seconds`` for segmentation: the
      low-budget strategies cost 2-3x Random's), each cold-start arm's first batch per
      run seed (``first_batch_seconds``), and the paired statistics over every seed.
    """
    entry = config["datasets"][dataset]
    if not EMBEDDING.settings(entry):
        return {"encoder_s": 0.0, "probe_s": 0.0, "jobs": 0}
    runs = dataset_runs(config, dataset, EMBEDDING)
    report_s = REPORT_S_PER_RUN * len(runs)  # the paired statistics over every seed
    if EMBEDDING.settings(entry).get(SHARED):  # another dataset's encoders and runs
        methods = {method for method, _seed in runs}
        return {"encoder_s": 0.0, "probe_s": report_s, "jobs": len(methods) + REPORT_JOBS}
    n_encoders = len(encoder_seeds(entry))
    per_encoder = encoder_seconds(entry, steps=steps, threads=int(config.get("threads_per_job", 1)))
    n_pool, n_test, _ = split_sizes(entry)
    dense = entry["task"] == "segmentation"
    per_method: dict[str, int] = {}
    for (method, _seed), rounds in runs.items():
        per_method[method] = per_method.get(method, 0) + int(rounds)
    width = int(encoder_recipe(entry).get("width", 32 if dense else 16))
    sizes = dict(n_pool=n_pool, n_test=n_test, m=int(entry["variants"]["n"]))
    sizes.update(dim=width + 9 if dense else 8 * width, n_labeled=labeled_at(entry["al"], 1))
    if dense:
        shape = entry["synthesis"]["image_shape"]
        sizes["n_test"] = int(n_test * shape[0] * shape[1] * DENSE_TEST_SHARE)
    round_seconds = dense_round_seconds if dense else probe_round_seconds
    probe_s = sum(
        rounds * round_seconds(dataset_method(config, dataset, method), **sizes)
        for method, rounds in per_method.items()
    )
    starts: dict[str, int] = {}  # cold-start arms: a first batch chosen per run seed
    for method, _seed in runs:
        start = dataset_method(config, dataset, method).initial
        if start:
            starts[start] = starts.get(start, 0) + 1
    probe_s += sum(
        count
        * first_batch_seconds(
            start, n_pool=n_pool, dim=sizes["dim"], size=int(entry["al"]["initial"])
        )
        for start, count in starts.items()
    )
    return {
        "encoder_s": n_encoders * per_encoder,
        "probe_s": probe_s + report_s,
        "jobs": n_encoders + len(per_method) + REPORT_JOBS,
    }


def estimate_config(config: dict, jobs: int = 2, steps: int = STEPS, log=print) -> dict:
    """Predicted seconds of a merged config's run, ``jobs`` at a time: ``{"wall_s",
    "jobs", "rows"}`` with one table row per dataset (``HEADER``). Datasets whose size
    only their files know (folders, captures, unlabeled) are named through ``log`` and
    left out."""
    import tempfile

    warm = bool(config.get("warm_worker", True))
    rows, total_core, total_jobs = [], 0.0, FIXED_JOBS
    with tempfile.TemporaryDirectory() as tmp:
        for dataset, entry in config["datasets"].items():
            if not is_synthesised(entry):
                log(f"{dataset}: source {entry.get('source')!r} is not estimated (its size "
                    "is known only from its files).")  # fmt: skip
                continue
            part = estimate_dataset(config, dataset, tmp=Path(tmp), steps=steps, jobs=jobs)
            framework = embedding_seconds(config, dataset)
            part["jobs"] += framework["jobs"]
            embed_s = framework["encoder_s"] + framework["probe_s"]
            core = part["train_s"] + part["forward_s"] + part["data_s"] + embed_s
            core += part["jobs"] * (JOB_START_S[warm] + SCHEDULER_S_PER_JOB)
            total_core += core
            total_jobs += part["jobs"]
            rows.append(
                [dataset, part["precision"], f"{part['train_rate']:.0f}",
                 str(part["trainings"]), str(part["jobs"]), f"{part['train_s'] / 60:.1f}",
                 f"{part['forward_s'] / 60:.1f}", f"{part['data_s'] / 60:.1f}",
                 f"{embed_s / 60:.1f}", f"{core / jobs / 60:.1f}"]
            )  # fmt: skip
    return {"wall_s": total_core / jobs, "jobs": total_jobs, "rows": rows}


HEADER = ["dataset", "precision", "train images/s", "trainings", "jobs", "train core-min",
          "eval+score core-min", "data core-min", "embedding core-min",
          "wall min"]  # fmt: skip


ESTIMATE_ENV = "SPL_AL_ESTIMATE"
"""Set to 0 to leave the time estimate out of the plan (it times each model first)."""


def estimate_minutes(config: dict, jobs: int = 2) -> float | None:
    """Predicted wall minutes of the run (``estimate_config`` at the command line's
    ``STEPS``: fewer steps weigh each training call's fixed cost more, and the plan
    of a 10.7-min run on a bf16 EPYC had said 14 at 10 steps), or None when
    ``$SPL_AL_ESTIMATE`` is 0 or the config cannot be estimated (a dataset known only
    from its files)."""
    if os.environ.get(ESTIMATE_ENV, "1") == "0":
        return None
    try:
        skipped: list[str] = []
        result = estimate_config(config, jobs, steps=STEPS, log=skipped.append)
    except Exception:  # an estimate is a courtesy, never a failed run
        return None
    return None if skipped or not result["rows"] else result["wall_s"] / 60


def main(argv: list[str]) -> int:
    """Print the estimate table of a config; the exit code."""
    parser = argparse.ArgumentParser(prog="python -m spl_al.bench estimate", description=__doc__)
    parser.add_argument(
        "--configfile", type=Path, nargs="*", default=[], help="override files, as Snakemake's"
    )
    parser.add_argument("--jobs", "-j", type=int, default=2, help="jobs at a time (snakemake -j)")
    parser.add_argument("--steps", type=int, default=STEPS, help="timed training steps per model")
    args = parser.parse_args(argv)
    missing = [str(p) for p in args.configfile if not p.is_file()]
    if missing:
        parser.error(f"--configfile {', '.join(missing)}: no such file (give YAML config files)")
    config = merged_config(args.configfile)
    result = estimate_config(config, args.jobs, args.steps)
    wall = result["wall_s"]
    rows = [*result["rows"], ["**total**", "", "", "", str(result["jobs"]), "", "", "",
                              f"**{wall / 60:.1f}**"]]  # fmt: skip
    threads = int(config.get("threads_per_job", 1))
    print(
        f"## Estimated wall time of `snakemake -j{args.jobs}` ({cpu_name()}, {os.cpu_count()} "
        f"cores, {threads} thread(s) per job, load average {os.getloadavg()[0]:.2f}, "
        f"{time.strftime('%Y-%m-%d')})\n"
    )
    print(markdown_table(HEADER, rows))
    print(
        f"\nPredicted: {wall / 60:.0f} min for {result['jobs']} jobs. Core minutes by part; "
        "wall = core time / jobs at a time (a prediction: docs/benchmarks.md#estimate)."
    )
    return 0

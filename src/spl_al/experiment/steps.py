"""One function per workflow rule: read inputs from disk, call the library, write outputs.

The Snakemake scripts in workflow/scripts only unpack the ``snakemake`` object and
call one of these, so every step can also be run from a notebook or another
scheduler. Index convention: labeled sets and queries are indices into the
dataset's *training split* (``dataset.train_idx[i]`` is the sample), kept as JSON.

Heavy imports (torch, scikit-learn, pandas, matplotlib) happen inside the steps that
need them, so a step that does not train pays nothing for them.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from spl_al.atomic import atomic_write, read_json, write_json
from spl_al.experiment.plan import MethodSpec

# Streams of np.random.SeedSequence([seed, round, stream]): one per kind of draw.
_TRAIN_STREAM = 1
_QUERY_STREAM = 2


def step_seed(seed: int, round_: int, stream: int) -> int:
    """A 31-bit seed for one (run seed, round, kind of draw): independent streams."""
    return int(np.random.SeedSequence([int(seed), int(round_), stream]).generate_state(1)[0] >> 1)


# ---------------------------------------------------------------- data


def make_dataset(entry: dict, out_path) -> dict:
    """Synthesize (or import) a dataset's observed images and save them to ``out_path``.

    ``entry`` is the dataset's config: ``task``, ``source`` ("synthetic" or "folder"),
    ``path``, ``depth_key``, ``reflectance_key``, ``levels_file`` and ``n_per_class``
    for folders (``spl_al.data.load_folder``), ``standin`` (synthesize when the folder is not
    given) and ``synthesis`` (keyword arguments of the generator).
    """
    from spl_al.data import load_folder, make_classification_dataset, make_segmentation_dataset

    synthesis = dict(entry.get("synthesis", {}))
    if "image_shape" in synthesis:
        synthesis["image_shape"] = tuple(synthesis["image_shape"])
    standin = False
    if entry["source"] == "unlabeled":
        dataset = _unlabeled_dataset(entry, synthesis)
    elif entry["source"] == "folder" and entry.get("path"):
        root = Path(entry["path"])
        if not root.is_dir():
            raise ValueError(f"dataset folder {root} does not exist (config key 'path').")
        dataset = load_folder(
            root,
            depth_key=entry.get("depth_key", "depth_ssp"),
            reflectance_key=entry.get("reflectance_key"),
            image_shape=synthesis.get("image_shape"),
            test_fraction=synthesis.get("test_fraction", 0.3),
            seed=synthesis.get("seed", 0),
            levels_file=entry.get("levels_file"),
            n_per_class=entry.get("n_per_class"),
        )
    elif entry["source"] == "folder" and not entry.get("standin", False):
        raise ValueError(
            "dataset source is 'folder' but no 'path' is given; set 'path' or 'standin: true'."
        )
    else:
        standin = entry["source"] == "folder"
        make = (
            make_classification_dataset
            if entry["task"] == "classification"
            else make_segmentation_dataset
        )
        dataset = make(**synthesis)
    dataset.meta["synthetic_standin"] = standin
    dataset.save(out_path)
    return {"samples": len(dataset), "standin": standin}


def _unlabeled_dataset(entry: dict, synthesis: dict):
    """An unlabeled folder (human oracle); its seed labels' test rows are the test split."""
    from spl_al.data.unlabeled import load_unlabeled_folder

    if not entry.get("path") or not Path(entry["path"]).is_dir():
        raise ValueError(
            f"config key 'path': {entry.get('path')!r} is not a folder of depth files."
        )
    dataset = load_unlabeled_folder(
        entry["path"],
        entry.get("classes"),
        task=entry["task"],
        seed_labels=entry.get("seed_labels"),
        depth_key=entry.get("depth_key", "depth_ssp"),
        image_shape=synthesis.get("image_shape"),
    )
    if not dataset.test_idx.size:
        raise ValueError(
            "config key 'seed_labels': no row has split 'test'; label a few samples as test "
            "there, they measure the model every round."
        )
    return dataset


def make_variant_shard(
    observed_path, variants: dict, shard: int, out_path, sspi_weights=None
) -> dict:
    """SIV variants of one shard of the observed images (shards can run anywhere).

    ``variants.reconstruct_method`` picks the reconstruction of the variants (default:
    the dataset's own). With ``"sspi"`` the weights folder is ``sspi_weights`` (config
    ``photon.sspi_weights``) or ``$SPL_AL_SSPI_WEIGHTS``; it is exported to that
    variable so worker processes find it, and the expected time of the shard
    (one timed frame x the shard's variants) is printed first, into the job log.
    """
    from spl_al.data import Dataset
    from spl_al.photon import SensorParams
    from spl_al.variants import generate_variants, shard_indices

    dataset = Dataset.load(observed_path)
    sensor = getattr(SensorParams, variants["sensor"])() if variants.get("sensor") else None
    conditions = [tuple(c) for c in variants["conditions"]] if variants.get("conditions") else None
    method = variants.get("reconstruct_method")
    if method == "sspi":
        _announce_sspi_shard(
            dataset,
            sensor or dataset.sensor,
            conditions,
            len(shard_indices(len(dataset), (int(shard), int(variants["shards"]))))
            * int(variants["n"]),
            sspi_weights,
        )
    part = generate_variants(
        dataset,
        n_variants=int(variants["n"]),
        conditions=conditions,
        seed=int(variants["seed"]),
        shard=(int(shard), int(variants["shards"])),
        workers=1,
        sensor=sensor,
        method=method,
    )
    part.save(out_path)
    return {"shard": shard}


def _announce_sspi_shard(dataset, sensor, conditions, n_frames: int, sspi_weights) -> None:
    """Export the SSPI weights folder and print the shard's expected time: one frame (sample 0,
    the condition of median photon budget) timed, times the shard's variants. Variants are
    reconstructed on their returns' bounding box, so small objects take less."""
    import os

    from spl_al.photon.sspi.weights import ENV_VAR, weights_folder
    from spl_al.variants import default_conditions, variants_of_image

    os.environ[ENV_VAR] = str(weights_folder(sspi_weights).resolve())
    if n_frames == 0:
        return
    # The condition with the median photon budget msppp (1 + 1 / sbr): a typical frame.
    candidates = sorted(
        conditions or default_conditions(dataset), key=lambda c: c[0] * (1 + 1 / c[1])
    )
    condition = candidates[len(candidates) // 2]
    refl = None if dataset.reflectance is None else dataset.reflectance[0]

    def one_frame():
        rng = np.random.default_rng(0)
        variants_of_image(dataset.depth_m[0], refl, [condition], 1, sensor, rng, "sspi")

    one_frame()  # loads the weights once
    start = time.perf_counter()
    one_frame()
    per_frame = time.perf_counter() - start
    rows, cols = dataset.image_shape
    print(
        f"SSPI: {per_frame:.2f} s per {rows}x{cols}x{sensor.n_bins} frame (sample 0 at "
        f"MSPPP {condition[0]:g}, SBR {condition[1]:g}); this shard reconstructs {n_frames} "
        f"variants: expected about {per_frame * n_frames / 60:.1f} min",
        flush=True,
    )


def merge_variants(observed_path, shard_paths, out_path) -> dict:
    """Attach every shard's variants to the observed dataset and save the whole."""
    from spl_al.data import Dataset
    from spl_al.variants import VariantShard, attach_variants

    dataset = attach_variants(
        Dataset.load(observed_path), [VariantShard.load(p) for p in shard_paths]
    )
    dataset.save(out_path)
    return {"samples": len(dataset), "variants": dataset.n_variants}


def data_pictures(dataset_path, contact_path, variants_path) -> None:
    """Contact sheet (clean vs observed per class) and one sample's variants sheet."""
    from spl_al.data import Dataset, contact_sheet, variants_sheet

    dataset = Dataset.load(dataset_path)
    contact_sheet(dataset, contact_path)
    variants_sheet(dataset, int(dataset.test_idx[0]), variants_path)


# ---------------------------------------------------------------- active learning


def read_labeled(path) -> np.ndarray:
    """Training-split indices of a labeled set written by ``initial_set`` or ``query``."""
    record = read_json(path)
    if "pool_indices" not in record:
        raise ValueError(f"{path}: not a labeled set (no 'pool_indices').")
    return np.asarray(record["pool_indices"], dtype=np.int64)


def initial_set(dataset_path, al: dict, seed: int, out_path) -> dict:
    """The round-0 labeled set of a seed, shared by every method (paired comparison).

    Reads only the dataset's split sizes (and, when stratified, the training labels:
    drawing the initial set is the oracle's job, not a strategy's).
    """
    from spl_al.data import SCENE_FIELDS, Dataset
    from spl_al.pool import initial_labeled_set

    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    stratified = bool(al.get("stratified_initial", False)) and dataset.task == "classification"
    labels = dataset.labels[dataset.train_idx] if stratified else None
    idx = initial_labeled_set(
        len(dataset.train_idx), int(al["initial"]), int(seed), labels=labels, stratified=stratified
    )
    return write_initial_set(idx, seed, out_path)


def write_initial_set(idx, seed: int, out_path) -> dict:
    """Write a seed's round-0 labeled set (training-split indices) as its JSON record."""
    idx = np.asarray(idx)
    record = {
        "seed": int(seed),
        "round": 0,
        "n_labeled": int(idx.size),
        "pool_indices": np.sort(idx).tolist(),
    }
    write_json(record, out_path)
    return record


def _set_threads(threads: int | None) -> None:
    import torch

    if threads:
        torch.set_num_threads(int(threads))


def model_for(dataset, model_cfg: dict):
    """The configured model (``model_cfg``: arch and its parameters) for ``dataset``;
    an architecture that needs the scan grid (PointNet++) gets ``dataset.grid()``."""
    from spl_al.models import build_model, needs_grid

    cfg = dict(model_cfg)
    arch = cfg.pop("arch", None)
    if needs_grid(dataset.task, arch):
        cfg["grid"] = dataset.grid()
    return build_model(dataset.task, len(dataset.classes), arch=arch, **cfg)


def _fit_and_evaluate(
    dataset, pool_idx, given, setup, n_variants, seed, round_, device, threads, log
):
    """Train a fresh model on the labeled groups ``pool_idx`` (with ``n_variants``
    variants each) and evaluate it on the test split: (model, metrics, train images,
    training seconds)."""
    from spl_al.training import TrainConfig, evaluate, train

    started = time.perf_counter()
    cfg = TrainConfig.from_dict({**setup["train"].get("fit", {}), "num_threads": threads})
    depth, valid = dataset.groups(dataset.train_idx[pool_idx], n_variants=n_variants)
    targets = np.repeat(given, depth.shape[1], axis=0)
    images = depth.reshape(-1, *depth.shape[2:])
    model = model_for(dataset, setup["train"]["model"])
    model = train(
        model,
        images,
        valid.reshape(images.shape),
        targets,
        cfg,
        seed=step_seed(seed, round_, _TRAIN_STREAM),
        device=device,
        log=log,
        groups=len(pool_idx),
    )
    train_seconds = time.perf_counter() - started
    test = dataset.test_idx
    metrics = evaluate(
        model,
        dataset.depth_m[test],
        dataset.valid[test],
        dataset.labels[test],
        levels=dataset.level[test],
        classes=dataset.classes,
        device=device,
        batch_size=cfg.eval_batch_size,
    )
    return model, metrics, int(images.shape[0]), train_seconds


def train_initial(
    dataset_path,
    labeled_path,
    setup: dict,
    n_variants: int,
    seed: int,
    model_path,
    fit_path,
    scores_path=None,
    device: str = "auto",
    threads: int | None = None,
    log=None,
) -> dict:
    """Round 0's training and scoring, done once per seed and number of variants per group.

    Every method starts from the seed's initial labeled set and trains with the same
    seed, so all methods that use ``n_variants`` variants per group (0: observed
    images only) would train the same model; ``train_round`` reuses this one instead
    (``initial_fit``). Writes the weights and ``fit_path`` (test metrics, training
    images and seconds, what a metrics record needs of the dataset). With
    ``scores_path`` it also scores the unlabeled pool for every strategy at once:
    every need on the observed images (batched as ``score_pool`` batches them for one
    strategy, so each method's part is what it would compute itself) and, when
    ``n_variants`` > 0, the group needs on the M = ``n_variants`` variants.
    """
    import torch

    from spl_al.data import SCENE_FIELDS, Dataset
    from spl_al.scoring import compute_inputs
    from spl_al.strategies import StrategyInputs
    from spl_al.strategies.inputs import ARRAY_FIELDS, GROUP_NEEDS, NEEDS

    _set_threads(threads)
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    pool_idx = read_labeled(labeled_path)
    given = dataset.labels[dataset.train_idx[pool_idx]]
    m = int(n_variants)
    model, metrics, n_images, seconds = _fit_and_evaluate(
        dataset, pool_idx, given, setup, m, seed, 0, device, threads, log
    )
    state = model.state_dict()
    atomic_write(model_path, lambda tmp: torch.save(state, tmp))
    fit = {
        "metrics": metrics,
        "train_images": n_images,
        "train_seconds": round(seconds, 3),
        "dataset": _dataset_facts(dataset),
        "score_variants": m,
    }
    if scores_path is not None:
        started = time.perf_counter()
        unlabeled = np.setdiff1d(np.arange(len(dataset.train_idx)), pool_idx)
        passes = [(0, frozenset(NEEDS) - GROUP_NEEDS)] + ([(m, GROUP_NEEDS)] if m else [])
        parts = {}
        for m_scored, needs in passes:
            depth, valid = dataset.groups(dataset.train_idx, n_variants=m_scored)
            inputs = compute_inputs(model, needs, depth, valid, unlabeled, pool_idx, device=device)
            parts.update(
                {f: getattr(inputs, f) for f in ARRAY_FIELDS if getattr(inputs, f) is not None}
            )
        StrategyInputs(unlabeled_idx=unlabeled, labeled_idx=pool_idx, **parts).save(scores_path)
        fit["score_seconds"] = round(time.perf_counter() - started, 3)
    write_json(fit, fit_path)
    return fit


def _dataset_facts(dataset) -> dict:
    """What a metrics record needs of a dataset, for steps that do not load it."""
    return {
        "task": dataset.task,
        "n_samples": len(dataset),
        "n_train": len(dataset.train_idx),
        "n_variants": int(dataset.n_variants),
        "synthetic_standin": bool(dataset.meta.get("synthetic_standin", False)),
    }


def _score_variants(method: MethodSpec, needs, n_variants: int) -> int:
    """Variants per group a strategy's scoring runs on: its method's M when it needs
    group predictions (DUIS), else 0 (observed images only)."""
    from spl_al.strategies.inputs import GROUP_NEEDS

    return _method_variants(method, n_variants) if needs & GROUP_NEEDS else 0


def _metrics_record(
    facts, setup, dataset_name, method_name, seed, round_, n_labeled, metrics, timing
) -> dict:
    """The per-round record ``spl_al.report`` aggregates (``facts``: ``_dataset_facts``)."""
    from spl_al.data.dataset import LEVELS

    key = "accuracy" if facts["task"] == "classification" else "miou"
    ratio_of = setup.get("ratio_of", "train")
    n_total = facts["n_samples"] if ratio_of == "all" else facts["n_train"]
    return {
        "dataset": dataset_name,
        "method": method_name,
        "seed": int(seed),
        "round": int(round_),
        "n_labeled": int(n_labeled),
        "n_pool": facts["n_train"],
        "n_total": int(n_total),
        "ratio": n_labeled / n_total,
        "metric": key,
        "value": float(metrics[key]),
        # Images without a known MSPPP level ("unknown": folder data without
        # conditions) count in "value" but belong to no level.
        "per_level": {
            level: float(v[key])
            for level, v in metrics.get("per_level", {}).items()
            if v[key] is not None and level in LEVELS  # not "unknown" (external files)
        },
        "synthetic_standin": facts["synthetic_standin"],
        **timing,
        "details": metrics,
    }


def _shared_round0(
    fit_path, scores_path, weights, method, pool_idx, model_path, out_scores, method_name
):
    """Round 0 from ``train_initial``'s files without torch: the fit record, the
    weights copied, and the method's part of the shared scores; None when the shared
    scores lack the variants this method scores on (it then scores itself)."""
    import shutil

    from spl_al.strategies import StrategyInputs, get
    from spl_al.strategies.inputs import NEEDS

    fit = read_json(fit_path)
    m = _train_variants(method, fit["dataset"]["n_variants"])
    _check_fit(fit, fit_path, pool_idx.size, m, method_name)
    needs = get(method.strategy, **method.params).needs
    if _score_variants(method, needs, fit["dataset"]["n_variants"]) not in (
        0,
        fit["score_variants"],
    ):
        return None
    shared = StrategyInputs.load(scores_path)
    if not np.array_equal(shared.labeled_idx, pool_idx):
        raise ValueError(f"{scores_path} scored another labeled set than round 0 of {method_name}.")
    wanted = {f for need in needs for f in NEEDS[need]}
    arrays = {f: getattr(shared, f) for f in wanted if getattr(shared, f) is not None}
    StrategyInputs(shared.unlabeled_idx, shared.labeled_idx, **arrays).save(out_scores)
    atomic_write(model_path, lambda tmp: shutil.copyfile(weights, tmp))
    return fit


def _train_variants(method: MethodSpec, n_variants: int) -> int:
    """Variants per labeled group a method trains on (0: observed images only)."""
    return _method_variants(method, n_variants) if method.use_variants else 0


def _method_variants(method: MethodSpec, n_variants: int) -> int:
    """A method's M: its own ``n_variants`` (the M sweep), else the dataset's."""
    return n_variants if method.n_variants is None else int(method.n_variants)


def _check_fit(fit, fit_path, n_labeled, m, method_name) -> None:
    if fit["train_images"] != n_labeled * (m + 1):
        raise ValueError(
            f"{fit_path} trained on {fit['train_images']} images, but round 0 of "
            f"{method_name} trains on {n_labeled * (m + 1)}; remove it to retrain."
        )


def train_round(
    dataset_path,
    labeled_path,
    setup: dict,
    dataset_name: str,
    method_name: str,
    seed: int,
    round_: int,
    model_path,
    metrics_path,
    scores_path,
    device: str = "auto",
    threads: int | None = None,
    log=None,
    labels_path=None,
    initial_fit=None,
) -> dict:
    """Train on round r's labeled groups, evaluate on the test split, then score the
    unlabeled pool for the next query (``score_pool``) with the model still in memory.

    The training labels are the dataset's (the simulated oracle), or with
    ``labels_path`` the ones a person gave (``spl_al.labeling.save_labels``).
    ``initial_fit`` = (weights, fit record[, shared scores]) of ``train_initial``:
    round 0's model, trained once for every method that trains like this one, is
    used instead of training again (the same seed and images give the same weights).
    With the shared scores this step needs neither torch nor the dataset: it copies
    the weights and the method's part of the scores.

    ``setup`` holds ``train`` (``model``: arch and its parameters, ``fit``: a
    TrainConfig) and ``method`` (MethodSpec fields). A method with ``use_variants``
    trains on the observed image and the method's M variants of each labeled group,
    all with the group's label or mask. The metrics record is the one
    ``spl_al.report`` aggregates.
    """
    started = time.perf_counter()
    method = MethodSpec(name=method_name, **{"params": {}, **setup["method"]})
    pool_idx = read_labeled(labeled_path)
    if initial_fit is not None and len(initial_fit) == 3:
        weights, fit_path, shared_scores = initial_fit
        fit = _shared_round0(
            fit_path, shared_scores, weights, method, pool_idx, model_path, scores_path,
            method_name,
        )  # fmt: skip
        if fit is not None:
            timing = {
                "train_images": fit["train_images"],
                "train_seconds": fit["train_seconds"],
                "score_seconds": 0.0,
                "seconds": round(time.perf_counter() - started, 3),
            }
            record = _metrics_record(
                fit["dataset"], setup, dataset_name, method_name, seed, round_,
                pool_idx.size, fit["metrics"], timing,
            )  # fmt: skip
            write_json(record, metrics_path)
            return record

    import torch

    from spl_al.data import SCENE_FIELDS, Dataset

    _set_threads(threads)
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    m = _train_variants(method, dataset.n_variants)
    if initial_fit is not None:
        weights, fit_path = initial_fit[:2]
        fit = read_json(fit_path)
        _check_fit(fit, fit_path, pool_idx.size, m, method_name)
        model = model_for(dataset, setup["train"]["model"])
        model.load_state_dict(torch.load(weights, map_location="cpu", weights_only=True))
        model.eval()
        metrics, n_images, train_seconds = (
            fit["metrics"],
            fit["train_images"],
            fit["train_seconds"],
        )
    else:
        if labels_path is None:
            given = dataset.labels[dataset.train_idx[pool_idx]]
        else:
            from spl_al.labeling import labels_for

            given = labels_for(labels_path, pool_idx).astype(dataset.labels.dtype)
        model, metrics, n_images, train_seconds = _fit_and_evaluate(
            dataset, pool_idx, given, setup, m, seed, round_, device, threads, log
        )
    state = model.state_dict()
    atomic_write(model_path, lambda tmp: torch.save(state, tmp))
    scored = score_pool(model, dataset, pool_idx, method, scores_path, device=device)
    timing = {
        "train_images": n_images,
        "train_seconds": round(train_seconds, 3),
        "score_seconds": scored["seconds"],
        "seconds": round(time.perf_counter() - started, 3),
    }
    record = _metrics_record(
        _dataset_facts(dataset), setup, dataset_name, method_name, seed, round_,
        pool_idx.size, metrics, timing,
    )  # fmt: skip
    write_json(record, metrics_path)
    return record


def score_pool(model, dataset, labeled: np.ndarray, method: MethodSpec, out_path, device="auto"):
    """Forward passes over the unlabeled training groups: exactly what the method's
    strategy needs (``strategy.needs``), saved for the query step. No labels are read:
    the strategy inputs are built from images and the model alone."""
    from spl_al.scoring import compute_inputs
    from spl_al.strategies import get

    started = time.perf_counter()
    # What to compute depends on the strategy alone, not on its parameters.
    strategy = get(method.strategy, **method.params)
    unlabeled = np.setdiff1d(np.arange(len(dataset.train_idx)), labeled)
    m = _score_variants(method, strategy.needs, dataset.n_variants)
    depth, valid = dataset.groups(dataset.train_idx, n_variants=m)
    inputs = compute_inputs(model, strategy.needs, depth, valid, unlabeled, labeled, device=device)
    inputs.save(out_path)
    return {"unlabeled": int(unlabeled.size), "seconds": round(time.perf_counter() - started, 3)}


def score_round(
    dataset_path,
    labeled_path,
    model_path,
    setup: dict,
    method_name: str,
    out_path,
    device: str = "auto",
    threads: int | None = None,
) -> dict:
    """``score_pool`` for a saved model: rescore a round without retraining."""
    import torch

    from spl_al.data import SCENE_FIELDS, Dataset

    _set_threads(threads)
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    method = MethodSpec(name=method_name, **{"params": {}, **setup["method"]})
    model = model_for(dataset, setup["train"]["model"])
    model.load_state_dict(torch.load(model_path, map_location="cpu", weights_only=True))
    return score_pool(model, dataset, read_labeled(labeled_path), method, out_path, device)


def query_round(
    scores_path, labeled_path, method: dict, batch: int, seed: int, round_: int, out_path
) -> dict:
    """Select ``batch`` unlabeled groups with the method's strategy; the oracle labels
    them; write the next round's labeled set (``round_`` is that next round)."""
    from spl_al.pool import Pool
    from spl_al.strategies import StrategyInputs, get

    spec = MethodSpec(name="", **method)
    inputs = StrategyInputs.load(scores_path)
    labeled = read_labeled(labeled_path)
    rng = np.random.default_rng(step_seed(seed, round_ - 1, _QUERY_STREAM))
    picked = get(spec.strategy, **spec.params).select(inputs, int(batch), rng)
    n_train = int(labeled.size + inputs.unlabeled_idx.size)
    pool = Pool(n_train, labeled)
    pool.add(picked)
    record = {
        "seed": int(seed),
        "round": int(round_),
        "n_labeled": int(pool.n_labeled),
        "queried": np.asarray(picked, dtype=np.int64).tolist(),
        "pool_indices": pool.labeled_idx.tolist(),
    }
    write_json(record, out_path)
    return record


# ---------------------------------------------------------------- aggregation


def make_table(metrics_paths, kind: str, experiments: dict, sweeps: dict, out_stem) -> None:
    """One of the paper's tables (budget, levels, ablation, sensitivity) as CSV + MD + TeX."""
    from spl_al import report

    df = report.load_records(metrics_paths)
    metric = df["metric"].iloc[0]
    at_round = experiments.get(kind, {}).get("round")
    caption = {
        "budget": f"{metric} (%) vs labeling ratio, mean ± std over seeds",
        "levels": f"{metric} (%) per MSPPP level at round {at_round}",
        "ablation": f"ablation: {metric} (%) at round {at_round}",
        "sensitivity": f"parameter sensitivity of DUIS: {metric} (%)",
    }[kind]
    if kind == "budget":
        frame = report.budget_table(df, methods=experiments["budget"]["methods"])
    elif kind == "levels":
        frame = report.level_table(
            df, round=experiments["levels"]["round"], methods=experiments["budget"]["methods"]
        )
    elif kind == "ablation":
        frame = report.ablation_table(
            df, experiments["ablation"]["round"], rows=experiments["ablation"]["methods"]
        )
    elif kind == "sensitivity":
        renamed = {("m" if p == "n_variants" else p): v for p, v in sweeps.items()}
        rounds = {
            ("m" if p == "n_variants" else p): r
            for p, r in experiments["sensitivity"]["rounds"].items()
        }
        frame = report.sensitivity_table(df, renamed, rounds)
    else:
        raise ValueError(
            f"unknown table {kind!r}; expected budget, levels, ablation or sensitivity."
        )
    report.write_table(frame, out_stem, caption=caption)


def make_curves(metrics_paths, methods, png, pdf, title: str, per_level: bool = False) -> None:
    """Budget curves with ±std bands: overall, or one panel per MSPPP level."""
    from spl_al import report

    df = report.load_records(metrics_paths)
    df = df[df["method"].isin(methods)]
    plot = report.plot_level_curves if per_level else report.plot_curves
    plot(df, png, pdf, methods=methods, title=title)


def make_summary(metrics_paths, out_path, notes=()) -> dict:
    """Per method: area under the budget curve and final value (JSON), with ``notes``
    (one sentence each, e.g. why per-level results are missing)."""
    from spl_al import report

    result = report.summary(report.load_records(metrics_paths))
    result["notes"] = [str(n) for n in notes]
    write_json(result, out_path)
    return result


def make_stats(metrics_paths, experiments: dict, sweeps: dict, out: dict) -> None:
    """Paired statistics of a dataset: ``comparisons`` and ``claims`` (CSV + Markdown)
    and the AUBC chart. ``out``: paths by name (comparisons_csv, comparisons_md,
    claims_csv, claims_md, aubc_png, aubc_pdf). Claims are judged on the comparisons
    as written, so the two files cannot disagree."""
    import pandas as pd

    from spl_al import report
    from spl_al.atomic import atomic_write_text
    from spl_al.report.claims import claims, render_claims_markdown
    from spl_al.report.comparisons import comparisons, render_comparisons_markdown
    from spl_al.report.stat_figures import aubc_figure

    df = report.load_records(metrics_paths)
    renamed = {("m" if p == "n_variants" else p): v for p, v in sweeps.items()}
    frame = comparisons(df, experiments, renamed)
    atomic_write(out["comparisons_csv"], lambda tmp: frame.to_csv(tmp, index=False))
    stored = pd.read_csv(out["comparisons_csv"])
    atomic_write_text(out["comparisons_md"], render_comparisons_markdown(stored))
    verdicts = claims(stored)
    atomic_write(out["claims_csv"], lambda tmp: verdicts.to_csv(tmp, index=False))
    name = str(df["dataset"].iloc[0])
    atomic_write_text(out["claims_md"], render_claims_markdown(verdicts, dataset=name))
    methods = experiments.get("budget", {}).get("methods")
    budget = df if methods is None else df[df["method"].isin(methods)]
    if "budget" in experiments:
        budget = budget[budget["round"] < int(experiments["budget"]["rounds"])]
    report.save_figure(aubc_figure(budget, methods), out["aubc_png"], out["aubc_pdf"])

"""Active-learning round steps: the round-0 set, training with evaluation and scoring,
and the query.

Index convention: labeled sets and queries are indices into the dataset's *training
split* (``dataset.train_idx[i]`` is the sample), kept as JSON. Torch, scikit-learn
and the dataset are imported inside the steps that need them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from spl_al.atomic import atomic_write, read_json, write_json
from spl_al.cold_start import RANDOM, STRATIFIED, initial_strategy, is_cold_start, round0_set
from spl_al.data import SCENE_FIELDS, Dataset
from spl_al.data.label_files import labels_for
from spl_al.experiment.encoders import embeddings_source, load_embeddings
from spl_al.experiment.plan import MethodSpec
from spl_al.experiment.step_args import FRESH, ModelFiles, RoundId, RoundStart
from spl_al.frameworks import get_feature_space
from spl_al.linear_probe import embedding_features
from spl_al.pool import Pool, read_labeled
from spl_al.query import query_batch
from spl_al.report.records import round_record
from spl_al.seeding import TRAIN, round_seed
from spl_al.strategies import StrategyInputs, get
from spl_al.strategies.inputs import ARRAY_FIELDS, GROUP_NEEDS, NEEDS
from spl_al.training.compute import LOCAL, Compute

# ---------------------------------------------------------------- labeled sets


def initial_set(dataset_path, al: dict, seed: int, out_path, *, embeddings=None) -> dict:
    """The round-0 labeled set of a seed, shared by every method that starts the same
    way (paired comparison): ``al.initial_strategy`` (``spl_al.cold_start``).

    Reads the dataset's split sizes; when stratified the training labels (drawing the
    initial set is then the oracle's job, not a strategy's); for a cold start the
    run seed's encoder ``embeddings`` (``train_encoder``'s file) and no label.
    """
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    start = initial_strategy(al)
    if start == STRATIFIED and dataset.task != "classification":
        start = RANDOM  # stratified_initial only stratifies classes
    labels = dataset.labels[dataset.train_idx] if start == STRATIFIED else None
    idx, chosen = choose_initial(dataset, start, al, seed, embeddings=embeddings, labels=labels)
    return write_initial_set(idx, seed, out_path, chosen=chosen)


def choose_initial(dataset, start: str, al: dict, seed: int, *, embeddings=None, labels=None):
    """(training-split indices, how they were chosen) of ``start``'s round 0 on
    ``dataset``: ``cold_start.round0_set`` given the ``labels`` a stratified draw reads,
    or, for a cold start, the observed images' embeddings from the file ``embeddings``
    (its encoder named in the record)."""
    features = None
    if is_cold_start(start):
        if embeddings is None:
            raise ValueError(f"a {start} round 0 reads the encoder's embeddings; none given.")
        features = load_embeddings(embeddings, dataset)[0][:, 0]
    idx, chosen = round0_set(
        start,
        len(dataset.train_idx),
        int(al["initial"]),
        int(seed),
        labels=labels,
        embeddings=features,
        n_classes=len(dataset.classes),
    )
    if features is not None:
        chosen["encoder"] = embeddings_source(embeddings)
    return idx, chosen


def write_initial_set(idx, seed: int, out_path, chosen: dict | None = None) -> dict:
    """Write a seed's round-0 labeled set (training-split indices) as its JSON record;
    ``chosen``: how it was chosen (``cold_start.round0_set``), kept when not random."""
    idx = np.asarray(idx)
    record = {
        "seed": int(seed),
        "round": 0,
        "n_labeled": int(idx.size),
        "pool_indices": np.sort(idx).tolist(),
    }
    if chosen and chosen.get("strategy") != RANDOM:
        record["chosen_by"] = chosen
    write_json(record, out_path)
    return record


# ---------------------------------------------------------------- models


@dataclass
class Fit:
    """A trained model and what its round records of it."""

    model: object
    metrics: dict
    train_images: int
    train_seconds: float
    precision: str
    train_steps: int | None = None  # optimiser steps (None: a fit record that predates them)
    images_seen: int | None = None  # images drawn over those steps

    def steps(self) -> dict:
        """``train_steps`` and ``images_seen`` for a record (none when unknown)."""
        return {
            k: int(v)
            for k, v in (("train_steps", self.train_steps), ("images_seen", self.images_seen))
            if v is not None
        }


def fit_and_evaluate(
    dataset,
    pool_idx,
    *,
    given,
    train_setup: dict,
    n_variants,
    seed,
    round_,
    compute: Compute,
    log,
    warm_from=None,
) -> Fit:
    """Train a model on the labeled groups ``pool_idx`` (their labels or masks
    ``given``; ``n_variants`` variants each) and evaluate it on the test split.

    ``train_setup``: ``model`` (arch and parameters) and ``fit`` (a TrainConfig).
    ``compute``: resolved (``Compute.resolved``); its precision is the fit's, the one
    the ``Fit`` records (the evaluation runs at ``MEASURE_PRECISION``, fp32).
    ``warm_from``: the weights of the method's previous round; when given, training
    starts from them with ``fit`` updated by ``train_setup["warm_start"]`` (fewer
    steps), else from fresh weights.
    """
    # torch on demand (importing this module does not load it)
    from spl_al.models.configured import load_model, model_for
    from spl_al.training import evaluate
    from spl_al.training.groups import train_groups

    started = time.perf_counter()
    model = (
        model_for(dataset, train_setup["model"])
        if warm_from is None
        else load_model(dataset, train_setup["model"], warm_from).train()
    )
    fit = train_setup.get("fit", {})
    if warm_from is not None:
        fit = {**fit, **(train_setup.get("warm_start") or {}), "from_scratch": False}
    model, cfg, n = train_groups(
        dataset,
        dataset.train_idx[pool_idx],
        given=given,
        model=model,
        fit=fit,
        n_variants=n_variants,
        seed=round_seed(TRAIN, seed, round_),
        compute=compute,
        log=log,
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
        compute=compute.measuring(),  # (not the training's precision: see the docstring)
        batch_size=cfg.eval_batch_size,
    )
    groups = len(pool_idx)
    return Fit(
        model,
        metrics,
        n,
        train_seconds,
        compute.precision,
        train_steps=cfg.total_steps(n, groups),
        images_seen=cfg.images_seen(n, groups),
    )


def _fit_of_record(model, record: dict) -> Fit:
    """A ``Fit`` of ``train_initial``'s record (``model``: its weights loaded, or None)."""
    return Fit(
        model,
        record["metrics"],
        record["train_images"],
        record["train_seconds"],
        record["precision"],
        train_steps=record.get("train_steps"),
        images_seen=record.get("images_seen"),
    )


def dataset_facts(dataset) -> dict:
    """What a metrics record needs of a dataset, for steps that do not load it."""
    return {
        "task": dataset.task,
        "n_samples": len(dataset),
        "n_train": len(dataset.train_idx),
        "n_variants": int(dataset.n_variants),
        "synthetic_standin": bool(dataset.meta.get("synthetic_standin", False)),
    }


# ---------------------------------------------------------------- round 0, shared


def train_initial(
    dataset_path,
    labeled_path,
    *,
    setup: dict,
    n_variants: int,
    seed: int,
    out: ModelFiles,
    compute: Compute = LOCAL,
    log=None,
) -> dict:
    """Round 0's training and scoring, done once per seed and number of variants per group.

    Every method starts from the seed's initial labeled set and trains with the same
    seed, so all methods that use ``n_variants`` variants per group (0: observed
    images only) would train the same model; ``train_round`` reuses this one instead
    (``initial``). Writes the weights and ``out.record`` (test metrics, training
    images, optimiser steps, images seen and seconds, precision, what a metrics record
    needs of the dataset). With ``out.scores`` it also scores the unlabeled pool for
    every strategy at once: every need on the observed images (batched as
    ``score_pool`` batches them for one strategy, so each method's part is what it
    would compute itself) and, when ``n_variants`` > 0, the group needs on the M =
    ``n_variants`` variants.
    """
    # torch on demand (importing this module does not load it)
    from spl_al.models.configured import resolved_for, save_model

    compute.apply()
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    compute = resolved_for(compute, dataset, setup["train"]["model"])
    pool_idx = read_labeled(labeled_path)
    given = dataset.labels[dataset.train_idx[pool_idx]]
    m = int(n_variants)
    fit = fit_and_evaluate(
        dataset,
        pool_idx,
        given=given,
        train_setup=setup["train"],
        n_variants=m,
        seed=seed,
        round_=0,
        compute=compute,
        log=log,
    )
    save_model(fit.model, out.model)
    record = {
        "metrics": fit.metrics,
        "train_images": fit.train_images,
        **fit.steps(),
        "train_seconds": round(fit.train_seconds, 3),
        "precision": fit.precision,
        "dataset": dataset_facts(dataset),
        "score_variants": m,
    }
    if out.scores is not None:
        started = time.perf_counter()
        _score_every_need(
            fit.model,
            dataset,
            pool_idx=pool_idx,
            m=m,
            out_path=out.scores,
            compute=compute,
        )
        record["score_seconds"] = round(time.perf_counter() - started, 3)
    write_json(record, out.record)
    return record


def _score_every_need(model, dataset, *, pool_idx, m, out_path, compute) -> None:
    """Scores of the unlabeled pool for every strategy: the observed-image needs, and
    with ``m`` > 0 the group needs on M = ``m`` variants."""
    # torch on demand (importing this module does not load it)
    from spl_al.scoring import compute_inputs

    unlabeled = np.setdiff1d(np.arange(len(dataset.train_idx)), pool_idx)
    # a segmenter has no classifier head (the strategies that read one are refused there)
    no_head = {"head"} if model.task != "classification" else set()
    observed = frozenset(NEEDS) - GROUP_NEEDS - no_head
    passes = [(0, observed)] + ([(m, GROUP_NEEDS)] if m else [])
    parts = {}
    for m_scored, needs in passes:
        depth, valid = dataset.groups(dataset.train_idx, n_variants=m_scored)
        inputs = compute_inputs(
            model,
            needs,
            depth_m=depth,
            valid=valid,
            unlabeled_idx=unlabeled,
            labeled_idx=pool_idx,
            compute=compute.measuring(),
        )
        parts.update(
            {f: getattr(inputs, f) for f in ARRAY_FIELDS if getattr(inputs, f) is not None}
        )
    StrategyInputs(unlabeled_idx=unlabeled, labeled_idx=pool_idx, **parts).save(out_path)


def _score_variants(method: MethodSpec, needs, n_variants: int) -> int:
    """Variants per group a strategy's scoring runs on: its method's M when it needs
    group predictions (DUIS), else 0 (observed images only)."""
    return method.variants_seen(n_variants) if needs & GROUP_NEEDS else 0


def _check_fit(fit, fit_path, n_labeled, m, method_name) -> None:
    if fit["train_images"] != n_labeled * (m + 1):
        raise ValueError(
            f"{fit_path} trained on {fit['train_images']} images, but round 0 of "
            f"{method_name} trains on {n_labeled * (m + 1)}; remove it to retrain."
        )


def _shared_round0(initial: ModelFiles, method: MethodSpec, pool_idx, out: ModelFiles):
    """Round 0 from ``train_initial``'s files without torch: the fit record and the
    method's part of the shared scores (the weights copied to ``out.model``); None
    when the shared scores lack the variants this method scores on (it then scores
    itself)."""
    import shutil

    fit = read_json(initial.record)
    m = method.train_variants(fit["dataset"]["n_variants"])
    _check_fit(fit, initial.record, pool_idx.size, m, method.name)
    needs = get(method.strategy, **method.params).needs
    if _score_variants(method, needs, fit["dataset"]["n_variants"]) not in (
        0,
        fit["score_variants"],
    ):
        return None
    shared = StrategyInputs.load(initial.scores)
    if not np.array_equal(shared.labeled_idx, pool_idx):
        raise ValueError(
            f"{initial.scores} scored another labeled set than round 0 of {method.name}."
        )
    wanted = {f for need in needs for f in NEEDS[need]}
    arrays = {f: getattr(shared, f) for f in wanted if getattr(shared, f) is not None}
    atomic_write(out.model, lambda tmp: shutil.copyfile(initial.model, tmp))
    return fit, StrategyInputs(shared.unlabeled_idx, shared.labeled_idx, **arrays)


# ---------------------------------------------------------------- round r


def _metrics_record(facts, setup, which: RoundId, n_labeled, metrics, extra) -> dict:
    """The per-round record ``spl_al.report`` aggregates (``report.round_record``;
    ``facts``: ``dataset_facts``; ``extra``: training images, steps and images seen,
    timing and precision; the test metrics in full go last, as ``details``)."""
    key = "accuracy" if facts["task"] == "classification" else "miou"
    ratio_of = setup.get("ratio_of", "train")
    levels = metrics.get("per_level", {})
    return round_record(
        which.dataset,
        which.method,
        which.seed,
        which.round,
        n_labeled=n_labeled,
        n_pool=facts["n_train"],
        n_total=facts["n_samples"] if ratio_of == "all" else facts["n_train"],
        metric=key,
        value=metrics[key],
        per_level={level: v[key] for level, v in levels.items()},
        synthetic_standin=facts["synthetic_standin"],
        **extra,
        details=metrics,
    )


def train_round(
    dataset_path,
    labeled_path,
    *,
    setup: dict,
    which: RoundId,
    out: ModelFiles,
    compute: Compute = LOCAL,
    log=None,
    start: RoundStart = FRESH,
    score: bool = True,
    embeddings=None,
) -> dict:
    """Train on round r's labeled groups, evaluate on the test split, then score the
    unlabeled pool for the next query (``score_pool``) with the model still in memory.

    ``setup`` holds ``train`` (``model``: arch and its parameters, ``fit``: a
    TrainConfig) and ``method`` (MethodSpec fields). A method with ``use_variants``
    trains on the observed image and the method's M variants of each labeled group,
    all with the group's label or mask. Writes the weights, the metrics record that
    ``spl_al.report`` aggregates (``out.record``: with the round's optimiser steps,
    ``train_steps``, and the images they drew, ``images_seen``) and the scores.

    ``start`` (``RoundStart``): the training labels are the dataset's (the simulated
    oracle), or with ``start.labels_path`` the ones a person gave
    (``spl_al.data.label_files.save_labels``). ``start.initial``: ``train_initial``'s
    files: round 0's model, trained once for every method that trains like this one, is
    used instead of training again (the same seed and images give the same weights).
    With its scores this step needs neither torch nor the dataset: it copies the weights
    and the method's part of the scores. ``start.previous_model``: the weights of this
    method's round r - 1, when the dataset's ``train.warm_start`` is set: the round
    fine-tunes them (``fit_and_evaluate``).
    ``score``: False in a run's last round, whose scores no query reads: ``out.scores``
    then holds the index sets only (a query on it is refused, naming what is missing).
    ``embeddings``: the dataset's self-supervised embeddings (``embedding_steps``), for
    a method with ``features: embedding``: its features come from them
    (``linear_probe.embedding_features``).
    """
    initial = start.initial
    started = time.perf_counter()
    method = MethodSpec(name=which.method, **{"params": {}, **setup["method"]})
    pool_idx = read_labeled(labeled_path)
    if initial is not None and initial.scores is not None:
        from_shared = _shared_round0(initial, method, pool_idx, out)
        if from_shared is not None:
            shared, inputs = from_shared
            m = shared["dataset"]["n_variants"]
            _features_of(method, inputs, embeddings, m).save(out.scores)
            fit = _fit_of_record(None, shared)
            extra = _fit_facts(fit, score_seconds=0.0, started=started)
            record = _metrics_record(
                shared["dataset"], setup, which, pool_idx.size, fit.metrics, extra
            )
            write_json(record, out.record)
            return record

    # torch on demand (importing this module does not load it)
    from spl_al.models.configured import resolved_for, save_model

    compute.apply()
    dataset = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    compute = resolved_for(compute, dataset, setup["train"]["model"])
    fit = _round_model(
        dataset,
        pool_idx,
        setup=setup,
        method=method,
        which=which,
        compute=compute,
        log=log,
        start=start,
    )
    save_model(fit.model, out.model)
    scoring = time.perf_counter()
    if score:
        inputs = score_pool(fit.model, dataset, labeled=pool_idx, method=method, compute=compute)
    else:
        unlabeled = np.setdiff1d(np.arange(len(dataset.train_idx)), pool_idx)
        inputs = StrategyInputs(unlabeled_idx=unlabeled, labeled_idx=pool_idx)
    score_seconds = round(time.perf_counter() - scoring, 3) if score else 0.0
    _features_of(method, inputs, embeddings, dataset.n_variants).save(out.scores)
    extra = _fit_facts(fit, score_seconds=score_seconds, started=started)
    facts = dataset_facts(dataset)
    record = _metrics_record(facts, setup, which, pool_idx.size, fit.metrics, extra)
    write_json(record, out.record)
    return record


def _features_of(method: MethodSpec, inputs, embeddings, n_variants: int) -> StrategyInputs:
    """The round's strategy inputs, with their features swapped for the self-supervised
    embedding's when the method selects on it (a feature space that needs the encoder,
    ``features: embedding``)."""
    if not get_feature_space(method.features).needs_encoder:
        return inputs
    if embeddings is None:
        raise ValueError(
            f"method {method.name!r} selects on the self-supervised embedding "
            f"(features: {method.features}), but the round was given no embeddings file."
        )

    with np.load(embeddings, allow_pickle=False) as f:
        train = f["train"]
    n_images = 1 + method.variants_seen(n_variants)
    return embedding_features(inputs, train, n_images=n_images)


def _fit_facts(fit: Fit, *, score_seconds: float, started: float) -> dict:
    """What a round's metrics record holds of its fit: training images, optimiser steps
    and images seen, seconds (training, scoring, the whole step) and precision."""
    return {
        "train_images": fit.train_images,
        **fit.steps(),
        "train_seconds": round(fit.train_seconds, 3),
        "score_seconds": score_seconds,
        "seconds": round(time.perf_counter() - started, 3),
        "precision": fit.precision,
    }


def _round_model(dataset, pool_idx, *, setup, method, which, compute, log, start: RoundStart):
    """The round's model: round 0's shared fit loaded (``start.initial``), else one
    trained on the labels of ``pool_idx`` (the dataset's, or a person's from
    ``start.labels_path``), from fresh weights or from ``start.previous_model``'s."""
    # torch on demand (importing this module does not load it)
    from spl_al.models.configured import load_model

    m = method.train_variants(dataset.n_variants)
    initial = start.initial
    if initial is not None:
        record = read_json(initial.record)
        _check_fit(record, initial.record, pool_idx.size, m, which.method)
        return _fit_of_record(load_model(dataset, setup["train"]["model"], initial.model), record)
    if start.labels_path is None:
        given = dataset.labels[dataset.train_idx[pool_idx]]
    else:
        given = labels_for(start.labels_path, pool_idx).astype(dataset.labels.dtype)
    return fit_and_evaluate(
        dataset,
        pool_idx,
        given=given,
        train_setup=setup["train"],
        n_variants=m,
        seed=which.seed,
        round_=which.round,
        compute=compute,
        log=log,
        warm_from=start.previous_model,
    )


def score_pool(
    model,
    dataset,
    *,
    labeled: np.ndarray,
    method: MethodSpec,
    compute: Compute = LOCAL,
) -> StrategyInputs:
    """Forward passes over the unlabeled training groups: exactly what the method's
    strategy needs (``strategy.needs``), for the query step, on ``compute``'s device at
    ``MEASURE_PRECISION`` (fp32), whatever precision trained the model. No labels are
    read: the strategy inputs are built from images and the model alone."""
    # torch on demand (importing this module does not load it)
    from spl_al.scoring import compute_inputs

    # What to compute depends on the strategy alone, not on its parameters.
    strategy = get(method.strategy, **method.params)
    unlabeled = np.setdiff1d(np.arange(len(dataset.train_idx)), labeled)
    m = _score_variants(method, strategy.needs, dataset.n_variants)
    depth, valid = dataset.groups(dataset.train_idx, n_variants=m)
    return compute_inputs(
        model,
        strategy.needs,
        depth_m=depth,
        valid=valid,
        unlabeled_idx=unlabeled,
        labeled_idx=labeled,
        compute=compute.measuring(),
    )


def query_round(
    scores_path,
    labeled_path,
    *,
    method: dict,
    batch: int,
    seed: int,
    round_: int,
    out_path,
    dataset: str | None = None,
    method_name: str | None = None,
) -> dict:
    """Select ``batch`` unlabeled groups with the method's strategy; the oracle labels
    them; write the next round's labeled set (``round_`` is that next round).

    A k-means candidate pool strategy (DUIS, diversity) must draw N_cand from at least
    twice as many unlabeled groups: else one sentence naming ``dataset``/``method_name``,
    the round, N_cand and the pool (``CandidatePoolTooLarge``). The record gives the
    unlabeled pool's size, N_cand (None without a candidate pool) and their ratio.

    The picks are checked against the strategy contract whatever the strategy (one
    from another package may override ``select``): ``batch`` (or every remaining)
    distinct indices of unlabeled groups. Else ``StrategyContractError``, one sentence
    naming the round, the strategy and what it returned, and nothing is written."""
    spec = MethodSpec(name="", **method)
    inputs = StrategyInputs.load(scores_path)
    labeled = read_labeled(labeled_path)
    strategy = get(spec.strategy, **spec.params)
    n_unlabeled = int(inputs.n_unlabeled)
    n_cand = getattr(strategy, "n_cand", None)
    where = {"seed": seed, "round_": round_, "dataset": dataset, "method": method_name}
    picked = query_batch(strategy, spec.strategy, inputs, batch, **where)
    n_train = int(labeled.size + n_unlabeled)
    pool = Pool(n_train, labeled)
    pool.add(picked)
    record = {
        "seed": int(seed),
        "round": int(round_),
        "n_labeled": int(pool.n_labeled),
        "batch": int(batch),
        # the pool the query drew from, and the k-means candidate pool's share of it
        "n_unlabeled": n_unlabeled,
        "n_cand": None if n_cand is None else int(n_cand),
        "cand_ratio": None if n_cand is None or not n_unlabeled else n_cand / n_unlabeled,
        "queried": np.asarray(picked, dtype=np.int64).tolist(),
        "pool_indices": pool.labeled_idx.tolist(),
        # what the strategy decided beyond its picks (ProbCover's radius and coverage, ...)
        "decision": dict(strategy.decision),
    }
    write_json(record, out_path)
    return record

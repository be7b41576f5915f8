"""Active-learning round steps: round 0's shared fit, a round's training with
evaluation and scoring, and the query. Round 0's labeled set is drawn in ``round0``,
a model fitted in ``fits`` and the pool scored in ``pool_scores``.

Index convention: labeled sets and queries are indices into the dataset's *training
split* (``dataset.train_idx[i]`` is the sample), kept as JSON. Torch, scikit-learn
and the dataset are imported inside the steps that need them.
"""

from __future__ import annotations

import time

import numpy as np

from spl_al.atomic import atomic_write, read_json, write_json
from spl_al.data import SCENE_FIELDS, Dataset
from spl_al.data.dataset import HEADLINE_METRICS
from spl_al.data.label_files import labels_for
from spl_al.experiment.fits import dataset_facts, fit_and_evaluate, fit_facts, fit_of_record
from spl_al.experiment.plan import MethodSpec
from spl_al.experiment.pool_scores import score_every_need, score_pool, score_variants
from spl_al.experiment.step_args import FRESH, ModelFiles, RoundId, RoundStart
from spl_al.frameworks import get_feature_space
from spl_al.linear_probe import embedding_features
from spl_al.pool import Pool, read_labeled
from spl_al.report.records import round_record
from spl_al.round_query import query_batch
from spl_al.strategies import StrategyInputs, get
from spl_al.strategies.inputs import NEEDS
from spl_al.training.compute import LOCAL, Compute

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
        score_every_need(
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
    if score_variants(method, needs, fit["dataset"]["n_variants"]) not in (
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
    key = HEADLINE_METRICS[facts["task"]]
    ratio_of = setup.get("ratio_of", "train")
    levels = metrics.get("per_level", {})
    if setup.get("encoder") is not None:  # the self-supervised encoder the run reads
        extra = {**extra, "encoder": int(setup["encoder"])}
    return round_record(
        (which.dataset, which.method, which.seed, which.round),
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
    TrainConfig), ``method`` (MethodSpec fields) and, for a run that reads the
    dataset's self-supervised encoder, ``encoder``: its seed, which the record names.
    A method with ``use_variants`` trains on the observed image and the method's M
    variants of each labeled group, all with the group's label or mask. Writes the
    weights, the metrics record that ``spl_al.report`` aggregates (``out.record``: with
    the round's optimiser steps, ``train_steps``, and the images they drew,
    ``images_seen``) and the scores.

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
            fit = fit_of_record(None, shared)
            extra = fit_facts(fit, score_seconds=0.0, started=started)
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
    extra = fit_facts(fit, score_seconds=score_seconds, started=started)
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
        return fit_of_record(load_model(dataset, setup["train"]["model"], initial.model), record)
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

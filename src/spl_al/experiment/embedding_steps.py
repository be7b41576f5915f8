"""Steps of the embedding framework: the self-supervised encoder of a dataset, and every
round of one method's runs on its frozen embeddings.

``train_encoder`` learns the encoder once per dataset from the training pool's images
(never a label, never a test image) and writes its weights, its card and the
embeddings of every image. ``probe_runs`` then plays one method's whole active-learning
runs, every seed and round, in one process: each round fits a linear classifier
(``spl_al.linear_probe``) on the labeled groups' embeddings, measures it on the test
split, and queries with the method's strategy from what that classifier and the
embeddings give (``probe_inputs``). A round takes milliseconds, so 100 seeds fit in
one job.

The round-0 sets are the seeds' own (``spl_al.cold_start.round0_set``, as the
supervised framework's ``initial_set`` chooses them; a cold start reads the run seed's
encoder), and the query is the supervised framework's (``spl_al.round_query.query_batch``,
its random stream keyed by the run seed and the round just trained): the two frameworks
differ in the model alone.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from spl_al import __version__
from spl_al.atomic import atomic_write, read_json, write_json
from spl_al.cold_start import STRATIFIED, initial_strategy, is_cold_start, round0_set
from spl_al.data import SCENE_FIELDS, Dataset
from spl_al.data.dataset import LEVELS
from spl_al.deploy.card import file_sha256
from spl_al.experiment.encoders import load_embeddings
from spl_al.experiment.plan import MethodSpec, batch_of
from spl_al.experiment.step_args import ProbeRuns
from spl_al.frameworks import EMBEDDING
from spl_al.linear_probe import DEFAULT_C, DropoutHead, LinearProbe, probe_inputs
from spl_al.models.configured import save_model
from spl_al.pool import Pool
from spl_al.report.records import round_record
from spl_al.round_query import query_batch
from spl_al.seeding import TRAIN, round_rng
from spl_al.strategies import get
from spl_al.training.compute import LOCAL, Compute
from spl_al.training.contrastive import EncoderConfig, embed, encoder_health
from spl_al.training.contrastive import train_encoder as fit_encoder

FRAMEWORK = EMBEDDING.name
CARD_KEYS = ("dataset", "variants", "image_shape")


def encoder_card(*, dataset: str, variants: dict, image_shape, encoder: dict, record: dict):
    """The encoder's card: what it was trained on and how (JSON-ready)."""
    return {
        "framework": FRAMEWORK,
        "dataset": dataset,
        "variants": dict(variants),
        "image_shape": [int(s) for s in image_shape],
        "encoder": dict(encoder),
        "trained_on": "the training split's frames, every image of each group; no label",
        "precision": "fp32",
        "spl_al_version": __version__,
        **record,
    }


def check_card(
    card: dict, *, dataset: str, variants: dict, image_shape, where, encoder_seed=None
) -> None:
    """A ValueError, one sentence naming what differs, unless the encoder's ``card`` was
    trained on ``dataset`` with these ``variants`` settings and ``image_shape`` (and,
    given ``encoder_seed``, with that seed)."""
    expected = {
        "dataset": dataset,
        "variants": dict(variants),
        "image_shape": [int(s) for s in image_shape],
    }
    if encoder_seed is not None:
        got = (card.get("encoder") or {}).get("seed")
        if got != int(encoder_seed):
            raise ValueError(
                f"{where}: the encoder was trained with seed {got!r}, but these run seeds read "
                f"encoder seed {int(encoder_seed)}; train it again (remove it and rerun)."
            )
    for key in CARD_KEYS:
        if card.get(key) != expected[key]:
            raise ValueError(
                f"{where}: the encoder was trained with {key} {card.get(key)!r}, but this run "
                f"has {key} {expected[key]!r}; train the encoder again for this dataset "
                "(remove it and rerun)."
            )


def train_encoder(
    dataset_path,
    *,
    dataset: str,
    encoder: dict,
    variants: dict,
    out: dict,
    compute: Compute = LOCAL,
    log=None,
) -> dict:
    """Train the dataset's encoder on its training split and embed every image.

    ``encoder``: config ``embedding.encoder`` (``EncoderConfig``); ``variants``: the
    dataset's config ``variants`` (recorded on the card). ``out``: paths ``encoder``
    (weights), ``card`` (JSON), ``embeddings`` (.npz: ``train`` (n_train, G, d) of
    every image of each training group, ``test`` (n_test, d) of the test split's
    observed images, and the split's indices). Returns the card.
    """
    compute.apply()
    data = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    cfg = EncoderConfig.from_dict(encoder)
    depth, valid = data.groups(data.train_idx)
    model, record = fit_encoder(depth, valid, cfg=cfg, device=compute.device, log=log)
    started = time.perf_counter()
    n, g, h, w = depth.shape
    train = embed(model, depth.reshape(n * g, h, w), valid.reshape(n * g, h, w)).reshape(n, g, -1)
    test_depth = data.depth_m[data.test_idx]
    test = embed(model, test_depth, np.isfinite(test_depth))
    record["embed_seconds"] = round(time.perf_counter() - started, 3)
    health = encoder_health(record, train[:, 0])
    if health["verdict"] == "collapsed":
        # refused before anything is written: no run reads a collapsed encoder
        raise ValueError(
            f"{dataset}: the encoder of seed {cfg.seed} collapsed: {'; '.join(health['failed'])}; "
            "change its seed or recipe (datasets.NAME.embedding.encoder), see docs/method.md."
        )
    if log is not None and health["verdict"] != "healthy":
        print(
            f"{dataset}: encoder seed {cfg.seed} is {health['verdict']}: {health['failed']}",
            file=log,
        )
    save_model(model, out["encoder"])
    record["weights_sha256"] = file_sha256(out["encoder"])
    record["health"] = health

    def write(tmp):
        with open(tmp, "wb") as fh:
            np.savez(fh, train=train, test=test, train_idx=data.train_idx, test_idx=data.test_idx)

    atomic_write(out["embeddings"], write)
    card = encoder_card(
        dataset=dataset,
        variants=variants,
        image_shape=(h, w),
        encoder=cfg.as_dict(),
        record={"frames": int(n), "images_per_frame": int(g), **record},
    )
    write_json(card, out["card"])
    return card


@dataclass(frozen=True)
class ProbeData:
    """What every run of a dataset reads: embeddings, the oracle's training labels (read
    for labeled groups only), the test split's labels and levels, and record facts."""

    train: np.ndarray  # (n_train, G, d)
    test: np.ndarray  # (n_test, d)
    train_labels: np.ndarray
    test_labels: np.ndarray
    test_levels: np.ndarray
    n_classes: int
    n_total: int
    standin: bool
    encoder: tuple[int, str] = (0, "healthy")  # (seed, health verdict) of the encoder


def probe_runs(dataset_path, encoders: dict, *, runs: ProbeRuns, out_path, log=None) -> list[dict]:
    """Every round of ``runs`` (one method, every seed) in the embedding framework.

    ``encoders``: encoder seed -> {"embeddings": path, "card": path} of every encoder
    ``runs.encoders`` names (run seed i reads ``runs.encoders[i]``). Writes a JSON list
    of metrics records (one per seed and round, as ``spl_al.report`` reads them, with
    ``framework: embedding``, the run's ``encoder`` seed and its health, and each
    round's labeled set) to ``out_path``.
    """
    dataset, method_name, al = runs.dataset, runs.method_name, runs.al
    from threadpoolctl import threadpool_limits

    data = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    facts = {}
    for eseed in sorted(set(runs.encoders)):
        if eseed not in encoders:
            raise ValueError(f"{dataset}/{method_name}: no files of encoder seed {eseed} given.")
        card = read_json(encoders[eseed]["card"])
        check_card(
            card,
            dataset=dataset,
            variants=runs.variants,
            image_shape=data.depth_m.shape[1:],
            where=encoders[eseed]["card"],
            encoder_seed=eseed,
        )
        emb_train, emb_test = load_embeddings(encoders[eseed]["embeddings"], data)
        facts[eseed] = ProbeData(
            train=emb_train,
            test=emb_test,
            train_labels=data.labels[data.train_idx],
            test_labels=data.labels[data.test_idx],
            test_levels=data.level[data.test_idx],
            n_classes=len(data.classes),
            n_total=len(data) if al.get("ratio_of", "train") == "all" else len(data.train_idx),
            standin=bool(data.meta.get("synthetic_standin", False)),
            encoder=(eseed, (card.get("health") or {}).get("verdict", "healthy")),
        )
    spec = MethodSpec(name=method_name, **{"params": {}, **runs.method})
    started = time.perf_counter()
    records = []
    # One BLAS/OpenMP thread, the job's one core: two -j2 jobs whose OpenMP threads
    # spin on the same two cores made a fit ~250x slower (7 s instead of 27 ms).
    with threadpool_limits(limits=1):
        for seed, eseed in zip(runs.seeds, runs.encoders, strict=True):
            records += _run(
                facts[eseed],
                spec,
                which=(dataset, int(seed)),
                al=al,
                rounds=int(runs.rounds),
                c=float((runs.probe or {}).get("c", DEFAULT_C)),
                n_variants=data.n_variants,
            )
    if log is not None:
        print(
            f"{dataset}/{method_name}: {len(records)} rounds of {len(runs.seeds)} seeds "
            f"({len(facts)} encoders) in {time.perf_counter() - started:.1f} s",
            file=log,
        )
    write_json(records, out_path)
    return records


def _record(facts: ProbeData, model, method: str, *, which, n_labeled, n_images) -> dict:
    """The metrics record of one round (``report.round_record``): ``model`` measured on
    the test split. ``which``: (dataset, seed, round); ``n_images``: the images it was
    fitted on."""
    dataset, seed, round_ = which
    correct = model.predict_proba(facts.test).argmax(axis=1) == facts.test_labels
    levels = facts.test_levels
    return round_record(
        (dataset, method, seed, round_),
        n_labeled=n_labeled,
        n_pool=len(facts.train),
        n_total=facts.n_total,
        metric="accuracy",
        value=correct.mean(),
        per_level={lv: correct[levels == lv].mean() for lv in LEVELS if (levels == lv).any()},
        synthetic_standin=facts.standin,
        framework=FRAMEWORK,
        train_images=int(n_images),
        precision=EMBEDDING.measured_at,  # a linear classifier fitted and measured in fp32
        encoder=int(facts.encoder[0]),
        encoder_health=facts.encoder[1],
    )


def _run(facts: ProbeData, spec: MethodSpec, *, which, al, rounds, c, n_variants) -> list[dict]:
    """The records of one (method, seed) run: fit, measure and query, round by round."""
    dataset, seed = which
    strategy = get(spec.strategy, **spec.params)
    m_train = spec.train_variants(n_variants)
    n_train = len(facts.train)
    start = spec.initial or initial_strategy(al, f"datasets.{dataset}.al")
    labeled, chosen = round0_set(
        start,
        n_train,
        int(al["initial"]),
        seed,
        labels=facts.train_labels if start == STRATIFIED else None,
        embeddings=facts.train[:, 0] if is_cold_start(start) else None,
        n_classes=facts.n_classes,
        where=f"datasets.{dataset}.al.initial",
    )
    pool = Pool(n_train, labeled)
    records = []
    for r in range(rounds):
        started = time.perf_counter()
        lab = pool.labeled_idx
        x = facts.train[lab, : m_train + 1].reshape(-1, facts.train.shape[-1])
        model = LinearProbe(facts.n_classes, c).fit(
            x, np.repeat(facts.train_labels[lab], m_train + 1)
        )
        fit_seconds = time.perf_counter() - started
        records.append(
            _record(
                facts,
                model,
                spec.name,
                which=(dataset, seed, r),
                n_labeled=lab.size,
                n_images=len(x),
            )
        )
        records[-1].update(train_seconds=round(fit_seconds, 4), pool_indices=lab.tolist())
        if r == 0:
            records[-1]["initial"] = chosen  # how round 0 was chosen (and its decision)
        if r + 1 == rounds:
            break
        head = None
        if "head" in strategy.needs:  # DropQuery's own head, trained under its dropout
            y = np.repeat(facts.train_labels[lab], m_train + 1)
            fitted = DropoutHead(facts.n_classes).fit(x, y, round_rng(TRAIN, seed, r))
            head = fitted.head()
        inputs = probe_inputs(
            model,
            facts.train,
            strategy.needs,
            unlabeled_idx=pool.unlabeled_idx,
            labeled_idx=lab,
            n_images=1 + spec.variants_seen(n_variants),
            head=head,
        )
        where = {"seed": seed, "round_": r + 1, "dataset": dataset, "method": spec.name}
        pool.add(query_batch(strategy, spec.strategy, inputs, batch_of(al, r + 1), **where))
        records[-1]["seconds"] = round(time.perf_counter() - started, 4)
        if strategy.decision:  # what the query after this round decided (ProbCover's radius, ...)
            records[-1]["query_decision"] = dict(strategy.decision)
    return records

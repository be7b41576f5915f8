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
from spl_al.blas_threads import one_thread
from spl_al.cold_start import STRATIFIED, initial_strategy, is_cold_start, round0_set
from spl_al.data import SCENE_FIELDS, Dataset
from spl_al.data.dataset import LEVELS
from spl_al.dense_probe import pooled_features
from spl_al.deploy.card import file_sha256
from spl_al.experiment import dense_embedding
from spl_al.experiment.dense_embedding import DenseProbeData, encode_scans, load_dense
from spl_al.experiment.encoders import load_embeddings
from spl_al.experiment.plan import MethodSpec, batch_of
from spl_al.experiment.step_args import ProbeRuns
from spl_al.frameworks import EMBEDDING
from spl_al.linear_probe import DEFAULT_C, LinearProbe, dropout_head, probe_inputs
from spl_al.models.configured import save_model
from spl_al.pool import Pool
from spl_al.report.records import round_record
from spl_al.round_query import query_batch
from spl_al.seeding import TRAIN, round_rng
from spl_al.strategies import get
from spl_al.strategies.inputs import StrategyInputs
from spl_al.training.compute import LOCAL, Compute
from spl_al.training.contrastive import EncoderConfig, embed, encoder_health
from spl_al.training.contrastive import train_encoder as fit_encoder
from spl_al.training.dense_contrastive import DenseEncoderConfig

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

    ``encoder``: config ``embedding.encoder`` (``EncoderConfig`` for classification,
    ``DenseEncoderConfig`` for segmentation); ``variants``: the dataset's config
    ``variants`` (recorded on the card). ``out``: paths ``encoder`` (weights), ``card``
    (JSON), ``embeddings`` (.npz with the split's indices and, for classification,
    ``train`` (n_train, G, d) of every image of each training group and ``test``
    (n_test, d) of the test split's observed images; for segmentation
    ``dense_embedding.encode_scans``'s units). Returns the card.
    """
    compute.apply()
    data = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    if data.task == "segmentation":
        cfg = DenseEncoderConfig.from_dict(encoder)
        model, record, arrays, observed = encode_scans(data, cfg, device=compute.device, log=log)
    else:
        cfg = EncoderConfig.from_dict(encoder)
        model, record, arrays = _embed_frames(data, cfg, compute=compute, log=log)
        observed = arrays["train"][:, 0]
    n, g, h, w = (*arrays["train"].shape[:2], *data.depth_m.shape[1:])
    health = encoder_health(record, observed)
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
            np.savez(fh, **arrays, train_idx=data.train_idx, test_idx=data.test_idx)

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


def _embed_frames(data, cfg: EncoderConfig, *, compute: Compute, log) -> tuple:
    """(encoder, record, {"train": (n_train, G, d), "test": (n_test, d)}) of a
    classification dataset: the encoder trained on the training groups, every image of
    each embedded, and the test split's observed images."""
    depth, valid = data.groups(data.train_idx)
    model, record = fit_encoder(depth, valid, cfg=cfg, device=compute.device, log=log)
    started = time.perf_counter()
    n, g, h, w = depth.shape
    train = embed(model, depth.reshape(n * g, h, w), valid.reshape(n * g, h, w)).reshape(n, g, -1)
    test_depth = data.depth_m[data.test_idx]
    test = embed(model, test_depth, np.isfinite(test_depth))
    record["embed_seconds"] = round(time.perf_counter() - started, 3)
    return model, record, {"train": train, "test": test}


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
    data = Dataset.load(dataset_path, skip=SCENE_FIELDS)
    health = {}
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
        health[eseed] = (card.get("health") or {}).get("verdict", "healthy")
    n_total = len(data) if al.get("ratio_of", "train") == "all" else len(data.train_idx)

    def facts_of(eseed):
        path, encoder = encoders[eseed]["embeddings"], (eseed, health[eseed])
        if data.task == "segmentation":
            return load_dense(path, data, n_total=n_total, encoder=encoder)
        emb_train, emb_test = load_embeddings(path, data)
        return ProbeData(
            train=emb_train,
            test=emb_test,
            train_labels=data.labels[data.train_idx],
            test_labels=data.labels[data.test_idx],
            test_levels=data.level[data.test_idx],
            n_classes=len(data.classes),
            n_total=n_total,
            standin=bool(data.meta.get("synthetic_standin", False)),
            encoder=encoder,
        )

    spec = MethodSpec(name=method_name, **{"params": {}, **runs.method})
    started = time.perf_counter()
    records = []
    facts = None  # one encoder's at a time: run seeds read their block's in order
    # One BLAS/OpenMP thread, the job's one core: two -j2 jobs whose OpenMP threads
    # spin on the same two cores made a fit ~250x slower (7 s instead of 27 ms).
    with one_thread():
        for seed, eseed in zip(runs.seeds, runs.encoders, strict=True):
            if facts is None or facts.encoder[0] != eseed:
                facts = facts_of(eseed)
            records += _run(
                facts,
                spec,
                which=(dataset, int(seed)),
                al=al,
                rounds=int(runs.rounds),
                probe=runs.probe or {},
                n_variants=data.n_variants,
            )
    if log is not None:
        print(
            f"{dataset}/{method_name}: {len(records)} rounds of {len(runs.seeds)} seeds "
            f"({len(health)} encoders) in {time.perf_counter() - started:.1f} s",
            file=log,
        )
    write_json(records, out_path)
    return records


def shared_runs(runs_path, dataset_path, source_path, *, dataset: str, source: str, out_path):
    """One method's runs of ``source``'s embedding framework as ``dataset``'s
    (config ``embedding: {shared: SOURCE}``): its records with ``dataset`` in place of
    ``source`` and ``runs_of: source`` beside it, written to ``out_path``. Refused
    (ValueError, nothing written) unless the two datasets' files hold the same scans,
    split and variants: then the experiment is the same, and its runs serve both."""
    with (
        np.load(dataset_path, allow_pickle=False) as a,
        np.load(source_path, allow_pickle=False) as b,
    ):
        for key in sorted(set(a.files) | set(b.files)):
            if key == "meta_json":  # names the dataset; the arrays are what runs read
                continue
            if (
                key not in a.files
                or key not in b.files
                or not np.array_equal(a[key], b[key], equal_nan=a[key].dtype.kind == "f")
            ):
                raise ValueError(
                    f"{dataset_path}: its '{key}' is not {source}'s ({source_path}), so "
                    f"{dataset} cannot share {source}'s embedding runs; expected the same "
                    "scans, split and variants, or an embedding block of its own."
                )
    records = [{**r, "dataset": dataset, "runs_of": source} for r in read_json(runs_path)]
    write_json(records, out_path)
    return records


class _LinearRounds:
    """A classification run's learner: ``LinearProbe`` on the groups' embeddings,
    accuracy on the test split."""

    metric = "accuracy"

    def __init__(self, facts: ProbeData, probe: dict) -> None:
        self.facts, self.c = facts, float(probe.get("c", DEFAULT_C))
        self.n_train, self.n_classes = len(facts.train), facts.n_classes
        self.labels = facts.train_labels  # the oracle's: read for labeled groups alone
        self.observed = facts.train[:, 0]  # what a cold start reads

    def fit(self, lab, n_images: int, rng) -> tuple:
        """(model, x, y) fitted on the first ``n_images`` images of groups ``lab``."""
        x = self.facts.train[lab, :n_images].reshape(-1, self.facts.train.shape[-1])
        y = np.repeat(self.labels[lab], n_images)
        return LinearProbe(self.n_classes, self.c).fit(x, y), x, y

    def measure(self, model) -> tuple[float, dict]:
        """(accuracy, level -> accuracy) on the test split."""
        facts = self.facts
        correct = model.predict_proba(facts.test).argmax(axis=1) == facts.test_labels
        levels = facts.test_levels
        per_level = {lv: correct[levels == lv].mean() for lv in LEVELS if (levels == lv).any()}
        return correct.mean(), per_level

    def inputs(self, model, needs, pool, *, n_images: int, head) -> StrategyInputs:
        return probe_inputs(
            model,
            self.facts.train,
            needs,
            unlabeled_idx=pool.unlabeled_idx,
            labeled_idx=pool.labeled_idx,
            n_images=n_images,
            head=head,
        )


class _DenseRounds:
    """A segmentation run's learner: ``DenseProbe`` on the scans' units, mIoU on the
    test split's pixels (``spl_al.experiment.dense_embedding``)."""

    metric = "miou"

    def __init__(self, facts: DenseProbeData, probe: dict) -> None:
        self.facts, self.probe = facts, dict(probe)
        self.n_train, self.n_classes = len(facts.train), len(facts.classes)
        self.labels = None  # no scan-level class: a stratified round 0 is refused
        self.observed = pooled_features(facts.train[:, 0], facts.train_valid[:, 0])
        self.previous = None

    def fit(self, lab, n_images: int, rng) -> tuple:
        """(model, x, y); each round's fit starts from the previous round's."""
        fitted = dense_embedding.fit_probe(
            self.facts, lab, n_images, probe=self.probe, rng=rng, start=self.previous
        )
        self.previous = fitted[0]
        return fitted

    def measure(self, model) -> tuple[float, dict]:
        return dense_embedding.test_miou(self.facts, model)

    def inputs(self, model, needs, pool, *, n_images: int, head) -> StrategyInputs:
        return dense_embedding.query_inputs(
            self.facts, model, needs, pool, n_images=n_images, head=head
        )


def _learner(facts, probe: dict):
    """The run's learner: the dense one for segmentation's facts."""
    dense = isinstance(facts, DenseProbeData)
    return _DenseRounds(facts, probe) if dense else _LinearRounds(facts, probe)


def _run(facts, spec: MethodSpec, *, which, al, rounds, probe: dict, n_variants) -> list[dict]:
    """The records of one (method, seed) run: fit, measure and query, round by round.

    ``facts``: ``ProbeData`` (classification) or ``dense_embedding.DenseProbeData``
    (segmentation); ``probe``: config ``embedding.probe``."""
    dataset, seed = which
    learner = _learner(facts, probe)
    strategy = get(spec.strategy, **spec.params)
    m_train = spec.train_variants(n_variants)
    start = spec.initial or initial_strategy(al, f"datasets.{dataset}.al")
    labeled, chosen = round0_set(
        start,
        learner.n_train,
        int(al["initial"]),
        seed,
        labels=learner.labels if start == STRATIFIED else None,
        embeddings=learner.observed if is_cold_start(start) else None,
        n_classes=learner.n_classes,
        where=f"datasets.{dataset}.al.initial",
    )
    pool = Pool(learner.n_train, labeled)
    records = []
    for r in range(rounds):
        started = time.perf_counter()
        lab = pool.labeled_idx
        rng = round_rng(TRAIN, seed, r)
        model, x, y = learner.fit(lab, m_train + 1, rng)
        fit_seconds = time.perf_counter() - started
        value, per_level = learner.measure(model)
        records.append(
            round_record(
                (dataset, spec.name, seed, r),
                n_labeled=lab.size,
                n_pool=learner.n_train,
                n_total=facts.n_total,
                metric=learner.metric,
                value=value,
                per_level=per_level,
                synthetic_standin=facts.standin,
                framework=FRAMEWORK,
                train_images=int(lab.size * (m_train + 1)),
                precision=EMBEDDING.measured_at,  # a linear classifier fitted and measured in fp32
                encoder=int(facts.encoder[0]),
                encoder_health=facts.encoder[1],
            )
        )
        records[-1].update(train_seconds=round(fit_seconds, 4), pool_indices=lab.tolist())
        if r == 0:
            records[-1]["initial"] = chosen  # how round 0 was chosen (and its decision)
        if r + 1 == rounds:
            break
        head = None
        if "head" in strategy.needs:  # DropQuery's own head, trained under its dropout
            head = dropout_head(x, y, learner.n_classes, rng).head()
        inputs = learner.inputs(
            model, strategy.needs, pool, n_images=1 + spec.variants_seen(n_variants), head=head
        )
        where = {"seed": seed, "round_": r + 1, "dataset": dataset, "method": spec.name}
        pool.add(query_batch(strategy, spec.strategy, inputs, batch_of(al, r + 1), **where))
        records[-1]["seconds"] = round(time.perf_counter() - started, 4)
        if strategy.decision:  # what the query after this round decided (ProbCover's radius, ...)
            records[-1]["query_decision"] = dict(strategy.decision)
    return records

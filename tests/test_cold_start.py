"""Round 0 chosen without a label (spl_al.cold_start): how it is configured, that the
first batch is the cold-start strategy's pick on the encoder's embeddings, that no
label reaches it (a leaking variant is caught), and how the plan refuses what cannot
run."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from spl_al.atomic import read_json
from spl_al.cold_start import (
    COLD_START,
    first_batch,
    initial_strategy,
    round0_set,
    split_start_name,
    start_name,
)
from spl_al.data.unlabeled_folder import load_unlabeled_folder
from spl_al.experiment import human, round0
from spl_al.experiment.plan import check_plan, dataset_runs, method_specs
from spl_al.pool import initial_labeled_set

ROOT = Path(__file__).resolve().parents[1]
CLASSES = ["car", "person", "bike"]


def blobs(n=60, d=8, seed=0):
    """Three well-separated clusters of embeddings (19-20 each) and three outliers."""
    rng = np.random.default_rng(seed)
    axes = np.eye(d) * 5  # clusters and outliers on orthogonal directions
    x = axes[np.arange(n) % 3] + rng.normal(size=(n, d)) * 0.3
    x[-3:] = axes[3:6] * 4  # outliers: alone on their directions, never typical
    return x.astype(np.float32)


# ------------------------------------------------------------------ configuration


def test_initial_strategy_reads_the_al_block_and_keeps_stratified_initial():
    assert initial_strategy({"initial": 5}) == "random"
    assert initial_strategy({"stratified_initial": True}) == "stratified"
    assert initial_strategy({"initial_strategy": "stratified", "stratified_initial": True}) == (
        "stratified"
    )
    assert initial_strategy({"initial_strategy": "typiclust"}) == "typiclust"
    with pytest.raises(ValueError, match=r"'datasets.d.al.initial_strategy': unknown strategy"):
        initial_strategy({"initial_strategy": "kmeans"}, "datasets.d.al")
    with pytest.raises(ValueError, match=r"stratified_initial' asks for a stratified round 0"):
        initial_strategy({"initial_strategy": "typiclust", "stratified_initial": True})


def test_random_and_stratified_round_0_are_the_draws_they_always_were():
    labels = np.arange(50) % 5
    idx, chosen = round0_set("random", 50, 10, 3)
    assert idx.tolist() == initial_labeled_set(50, 10, 3).tolist()
    assert chosen == {"strategy": "random"}
    idx, _ = round0_set("stratified", 50, 10, 3, labels=labels)
    expected = initial_labeled_set(50, 10, 3, labels=labels, stratified=True)
    assert idx.tolist() == expected.tolist()


def test_arm_names_round_trip():
    assert start_name("syn_maxherding", "probcover") == "syn_maxherding_from_probcover"
    assert split_start_name("syn_maxherding_from_probcover") == ("syn_maxherding", "probcover")
    assert split_start_name("duis") is None
    assert split_start_name("duis_from_kmeans") is None


# ------------------------------------------------------------------ the first batch


@pytest.mark.parametrize("strategy", COLD_START)
def test_a_cold_start_is_seeded_distinct_and_its_strategy_decides(strategy):
    x = blobs()
    a, decision = first_batch(x, 6, seed=1, strategy=strategy, n_classes=3)
    b, _ = first_batch(x, 6, seed=1, strategy=strategy, n_classes=3)
    assert a.tolist() == b.tolist() and len(set(a.tolist())) == 6
    assert a.tolist() == sorted(a.tolist()) and decision
    # three picks: one per cluster, which a random draw often misses, and no outlier
    # (never typical, representative or covering many)
    three, _ = first_batch(x, 3, seed=1, strategy=strategy, n_classes=3)
    assert not set(three.tolist()) & {57, 58, 59}
    assert sorted(int(i) % 3 for i in three) == [0, 1, 2]


def test_a_cold_start_asks_for_what_its_strategy_requires():
    """ProbCover declares its class count required (``Strategy.required``): without it
    the cold start stops in one sentence; the others need none."""
    with pytest.raises(ValueError, match="a probcover cold start needs n_classes"):
        first_batch(blobs(), 3, seed=1, strategy="probcover")
    assert len(first_batch(blobs(), 3, seed=1, strategy="maxherding")[0]) == 3


def test_typiclust_first_batch_is_the_cluster_centres():
    """TypiClust from zero labels picks the densest sample of each cluster."""
    x = blobs()
    picks, decision = first_batch(x, 3, seed=0, strategy="typiclust")
    assert decision["clusters"] == 3 and sorted(int(i) % 3 for i in picks) == [0, 1, 2]
    unit = x / np.linalg.norm(x, axis=1, keepdims=True)
    for i in picks:
        members = np.flatnonzero(np.arange(len(x)) % 3 == i % 3)[:19]
        dist = np.linalg.norm(unit[members] - unit[i], axis=1).mean()
        others = [np.linalg.norm(unit[members] - unit[j], axis=1).mean() for j in members]
        assert dist <= np.quantile(others, 0.25)


def test_round_0_larger_than_the_pool_is_refused_naming_the_key():
    with pytest.raises(ValueError, match=r"'datasets.d.al.initial' asks for 70 .* holds 60"):
        round0_set("typiclust", 60, 70, 1, embeddings=blobs(), where="datasets.d.al.initial")


# ------------------------------------------------------------------ no label read


def unlabeled_folder(tmp_path: Path, test_labels: list[str]) -> tuple[Path, Path]:
    """A folder of 60 frames (three shapes of scene) with a seed_labels.csv whose rows
    are the test split alone, labeled ``test_labels``; returns (dataset, its embeddings
    in the encoder's file layout, one 4-number summary per image)."""
    frames = tmp_path / "frames"
    frames.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    for k in range(60):
        depth = np.full((8, 12), 3.0 + (k % 3) * 2.0) + rng.normal(0, 0.05, (8, 12))
        np.savez(frames / f"frame_{k:04d}.npz", depth_ssp=depth.astype(np.float32))
    seed = tmp_path / "seed_labels.csv"
    rows = [
        f"frame_{k:04d}.npz,{name},test" for k, name in zip((57, 58, 59), test_labels, strict=True)
    ]
    seed.write_text("file,label,split\n" + "\n".join(rows) + "\n")
    data = load_unlabeled_folder(frames, CLASSES, seed_labels=seed)
    path = data.save(tmp_path / "dataset.npz")
    train = np.stack([_summary(data.depth_m[i]) for i in data.train_idx])[:, None]
    test = np.stack([_summary(data.depth_m[i]) for i in data.test_idx])
    emb = tmp_path / "embeddings.npz"
    np.savez(emb, train=train, test=test, train_idx=data.train_idx, test_idx=data.test_idx)
    return path, emb, seed


def _summary(depth):
    """A stand-in embedding whose direction tells the three scene depths apart (the
    cold-start strategies read directions: they normalise)."""
    return np.array([depth.mean() - 5.0, 1.0, depth.std(), 0.0], np.float32)


def first_batch_of_a_lab(tmp_path, test_labels, choose) -> list[int]:
    path, emb, seed = unlabeled_folder(tmp_path, test_labels)
    out = tmp_path / "initial.json"
    choose(path, emb, seed, out)
    return read_json(out)["pool_indices"]


def cold_start_as_shipped(path, emb, seed, out):
    al = {"initial": 4, "batch": 2, "initial_strategy": "typiclust"}
    human.initial_set(
        path, al, seed=1, out_path=out, oracle="human", seed_labels=seed, embeddings=emb
    )


def leaking_variant(path, emb, seed, out):
    """What a leak looks like: the first batch steered by the test rows' labels."""
    from spl_al.data import Dataset

    data = Dataset.load(path)
    shift = int(data.labels[data.test_idx].sum())
    idx, _ = round0_set("random", len(data.train_idx), 4, 1 + shift)
    round0.write_initial_set(idx, 1, out)


@pytest.mark.parametrize("choose", [cold_start_as_shipped, leaking_variant])
def test_the_first_batch_reads_no_label(tmp_path, choose):
    """The same frames with other test labels give the same first batch; the leaking
    variant fails this very check, so the check can fail."""
    a = first_batch_of_a_lab(tmp_path / "a", ["car", "person", "bike"], choose)
    b = first_batch_of_a_lab(tmp_path / "b", ["bike", "bike", "car"], choose)
    if choose is leaking_variant:
        assert a != b
    else:
        assert a == b


def test_a_lab_first_batch_is_typiclust_on_its_encoder_and_says_so(tmp_path):
    path, emb, seed = unlabeled_folder(tmp_path, ["car", "person", "bike"])
    (tmp_path / "card.json").write_text('{"encoder": {"seed": 7}, "weights_sha256": "ab"}')
    out = tmp_path / "initial.json"
    cold_start_as_shipped(path, emb, seed, out)
    record = read_json(out)
    with np.load(emb) as f:
        expected, _ = first_batch(f["train"][:, 0], 4, seed=1, strategy="typiclust")
    assert record["pool_indices"] == expected.tolist()
    assert record["chosen_by"]["strategy"] == "typiclust"
    assert record["chosen_by"]["encoder"]["encoder_seed"] == 7
    # three scene shapes, 57 training frames: the first batch spans all three
    depth = [round(float(v), 0) for v in np.load(emb)["train"][record["pool_indices"], 0, 0]]
    assert set(depth) == {-2.0, 0.0, 2.0}

    batch = human.label_batch(
        path, out, labels_file=tmp_path / "labels.csv", out_dir=tmp_path / "to_label"
    )
    assert batch["samples"] == 4
    readme = (tmp_path / "to_label" / "README.txt").read_text()
    assert "chosen by typiclust on the dataset's self-supervised encoder (encoder seed 7)" in (
        readme
    )


def test_a_simulated_oracle_cold_start_reads_no_training_label(tmp_path):
    """round0.initial_set on a labeled dataset: permuting every label changes
    nothing; stratified (which reads them) does change."""
    from spl_al.data import Dataset

    path, emb, _seed = unlabeled_folder(tmp_path, ["car", "person", "bike"])
    data = Dataset.load(path)
    picks = {}
    shuffled = np.random.default_rng(5).permutation(np.arange(len(data)) % 3)
    for name, labels in (("a", np.arange(len(data)) % 3), ("b", shuffled)):
        data.labels = labels.astype(data.labels.dtype)
        p = data.save(tmp_path / f"labeled_{name}.npz")
        for start in ("typiclust", "stratified"):
            al = {"initial": 6, "initial_strategy": start}
            out = tmp_path / f"{name}_{start}.json"
            round0.initial_set(p, al, 2, out, embeddings=emb)
            picks[name, start] = read_json(out)["pool_indices"]
    assert picks["a", "typiclust"] == picks["b", "typiclust"]
    assert picks["a", "stratified"] != picks["b", "stratified"]


# ------------------------------------------------------------------ the plan


def default_config() -> dict:
    return yaml.safe_load((ROOT / "config" / "config.yaml").read_text())


def test_the_cold_start_experiment_generates_its_arms_in_both_frameworks():
    config = default_config()
    specs = method_specs(config)
    arms = {n: s for n, s in specs.items() if s.initial}
    assert set(arms) == {
        start_name(b, s)
        for b in ("random", "syn_maxherding", "duis")
        for s in ("typiclust", "probcover", "maxherding")
    }
    assert arms["duis_from_typiclust"].strategy == "duis"
    assert arms["duis_from_typiclust"].as_dict()["initial"] == "typiclust"
    assert "initial" not in specs["duis"].as_dict()  # other methods' settings unchanged
    runs = dataset_runs(config, "real_cls", "embedding")
    assert ("syn_maxherding_from_probcover", 120) in runs


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            lambda c: (
                c["datasets"]["synth_cls"]["al"].update(initial_strategy="maxherding")
                or c["datasets"]["synth_cls"].pop("embedding")
            ),
            r"'datasets.synth_cls.al.initial_strategy': maxherding chooses round 0 on the "
            r"dataset's self-supervised embedding, but synth_cls has no 'embedding' block",
        ),
        (
            lambda c: c["datasets"]["street_seg"]["al"].update(initial_strategy="typiclust"),
            r"typiclust chooses round 0 for a classification dataset, but street_seg is a "
            r"segmentation dataset",
        ),
        (
            lambda c: c["datasets"]["real_cls"]["al"].update(initial_strategy="typiclust"),
            r"cold_start' compares first batches with a random one, but "
            r"'datasets.real_cls.al.initial_strategy' is 'typiclust'",
        ),
        (
            lambda c: c["datasets"]["synth_cls"]["al"].update(initial=771),
            r"'datasets.synth_cls.al.initial' asks for 771 .* holds 770",
        ),
    ],
)
def test_the_plan_refuses_a_round_0_it_cannot_choose(change, message):
    config = copy.deepcopy(default_config())
    change(config)
    with pytest.raises(ValueError, match=message):
        check_plan(config)

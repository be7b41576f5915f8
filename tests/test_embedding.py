"""The embedding framework: the self-supervised encoder learns without labels or test
images, its card refuses another dataset, and a round on frozen embeddings keeps the
strategy contract (never a label of an unlabeled group)."""

from __future__ import annotations

import itertools
import json
from dataclasses import replace

import numpy as np
import pytest
from helpers.al_synthetic import shapes_groups

from spl_al.data import Dataset
from spl_al.experiment.embedding_steps import check_card, probe_runs, train_encoder
from spl_al.experiment.step_args import ProbeRuns
from spl_al.report import load_records
from spl_al.strategies import names
from spl_al.training.contrastive import EncoderConfig, nt_xent

# enough steps for a healthy encoder (its loss well below chance: the health check)
ENCODER = {
    "width": 4,
    "steps": 40,
    "batch_size": 8,
    "projection_dim": 8,
    "input_pool": 1,
    "lr": 0.1,
}
VARIANTS = {"n": 2, "shards": 1, "seed": 0}
AL = {"initial": 6, "batch": 3, "ratio_of": "train"}
N_TRAIN = 24


def _dataset(tmp_path, labels=None, test_depth=None, name="dataset.npz"):
    depth, _, y = shapes_groups(30, n_groups=3, seed=1)
    n = len(y)
    observed = depth[:, 0].copy()
    if test_depth is not None:
        observed[N_TRAIN:] = test_depth
    data = Dataset(
        "classification",
        ["small", "medium", "large"],
        observed,
        (y if labels is None else labels).astype(np.int64),
        ["train"] * N_TRAIN + ["test"] * (n - N_TRAIN),
        np.full(n, 5.0),
        np.full(n, 1.0),
        ["high"] * 10 + ["medium"] * 10 + ["low"] * 10,
        variant_depth_m=depth[:, 1:],
        variant_msppp=np.full((n, 2), 2.0),
        variant_sbr=np.full((n, 2), 1.0),
    )
    path = tmp_path / name
    data.save(path)
    return path, data


def _encode(tmp_path, data_path, stem, encoder=ENCODER):
    out = {k: tmp_path / f"{stem}.{k}" for k in ("encoder", "card", "embeddings")}
    card = train_encoder(data_path, dataset="toy", encoder=encoder, variants=VARIANTS, out=out)
    return out, card


def _files(out, seed=0):
    """``probe_runs``'s encoder files: one encoder of seed ``seed``."""
    return {seed: {"embeddings": out["embeddings"], "card": out["card"]}}


def test_encoder_reads_no_label_and_no_test_image(tmp_path):
    path, data = _dataset(tmp_path)
    out, card = _encode(tmp_path, path, "a")
    shuffled = np.random.default_rng(0).permutation(data.labels)
    path_b, _ = _dataset(tmp_path, labels=shuffled, name="b.npz")
    out_b, _ = _encode(tmp_path, path_b, "b")
    assert out["encoder"].read_bytes() == out_b["encoder"].read_bytes()
    # other test images: the same encoder, only the test split's embeddings differ
    noisy = data.depth_m[N_TRAIN:] + 3.0
    path_c, _ = _dataset(tmp_path, test_depth=noisy, name="c.npz")
    out_c, _ = _encode(tmp_path, path_c, "c")
    assert out["encoder"].read_bytes() == out_c["encoder"].read_bytes()
    with np.load(out["embeddings"]) as a, np.load(out_c["embeddings"]) as c:
        np.testing.assert_array_equal(a["train"], c["train"])
        assert a["train"].shape == (N_TRAIN, 3, 32) and a["test"].shape == (6, 32)
    assert card["dataset"] == "toy" and card["variants"] == VARIANTS
    assert card["image_shape"] == list(data.depth_m.shape[1:]) and card["precision"] == "fp32"
    assert "spl_al_version" in card


def test_card_refuses_another_dataset_variants_or_shape():
    card = {"dataset": "toy", "variants": VARIANTS, "image_shape": [16, 16]}
    check_card(card, dataset="toy", variants=VARIANTS, image_shape=(16, 16), where="c")
    cases = [
        ({"dataset": "other"}, "dataset"),
        ({"variants": {**VARIANTS, "seed": 3}}, "variants"),
        ({"image_shape": (8, 16)}, "image_shape"),
    ]
    for change, key in cases:
        expected = {"dataset": "toy", "variants": VARIANTS, "image_shape": (16, 16), **change}
        with pytest.raises(ValueError, match=f"trained with {key}") as err:
            check_card(card, where="enc.card.json", **expected)
        assert str(err.value).count(". ") == 0  # one sentence


def test_nt_xent_prefers_matching_views():
    import torch

    z = torch.nn.functional.normalize(torch.randn(4, 8), dim=1)
    matched = nt_xent(torch.cat([z, z]), 0.2)
    shuffled = nt_xent(torch.cat([z, z[[1, 2, 3, 0]]]), 0.2)
    assert float(matched) < float(shuffled)


def test_encoder_config_names_unknown_keys():
    with pytest.raises(ValueError, match="unknown keys \\['widht'\\]"):
        EncoderConfig.from_dict({"widht": 3})


def _facts(rng, labels):
    from spl_al.experiment.embedding_steps import ProbeData

    return ProbeData(
        train=rng.normal(size=(60, 3, 8)).astype(np.float32),
        test=rng.normal(size=(20, 8)).astype(np.float32),
        train_labels=labels,
        test_labels=rng.integers(0, 4, 20),
        test_levels=np.array(["high"] * 20),
        n_classes=4,
        n_total=60,
        standin=True,
    )


def _labeled_sets(facts, strategy):
    """Every round's labeled set of one embedding-framework run (3 queries of 5)."""
    from spl_al.experiment.embedding_steps import _run
    from spl_al.experiment.plan import MethodSpec

    params = {"n_classes": 4} if strategy == "probcover" else {}
    if strategy in ("duis", "diversity"):
        params["n_cand"] = 12
    spec = MethodSpec(name=strategy, strategy=strategy, params=params, use_variants=True)
    al = {"initial": 10, "batch": 5}
    records = _run(facts, spec, which=("toy", 1), al=al, rounds=4, probe={"c": 1.0}, n_variants=2)
    return [r["pool_indices"] for r in records]


def _assert_hidden_labels_unread(strategy):
    """A run's labeled sets are the same whatever the labels of the groups it never
    labels: the strategy saw none of them."""
    rng = np.random.default_rng(0)
    labels = rng.integers(0, 4, 60)
    facts = _facts(np.random.default_rng(1), labels)
    first = _labeled_sets(facts, strategy)
    never = np.setdiff1d(np.arange(60), first[-1])
    other = labels.copy()
    other[never] = (labels[never] + 1 + rng.integers(0, 3, never.size)) % 4  # every one changes
    assert _labeled_sets(replace(facts, train_labels=other), strategy) == first
    assert _labeled_sets(facts, strategy) == first  # seeded
    for before, after in itertools.pairwise(first):
        added = sorted(set(after) - set(before))
        assert len(added) == 5 and set(before) <= set(after)  # no repeat, none relabeled


@pytest.mark.parametrize("strategy", sorted(set(names()) - {"skactiveml"}))
def test_embedding_round_keeps_the_strategy_contract(strategy):
    """Picks are distinct unlabeled groups, seeded, and the same whatever the hidden
    labels of the groups the run never labels (the oracle's labels reach the probe for
    labeled groups alone)."""
    _assert_hidden_labels_unread(strategy)


def test_the_contract_test_catches_a_round_that_leaks_hidden_labels(monkeypatch):
    """The test above fails on a round that hands the strategy features made from the
    labels of unlabeled groups (the oracle's, which it must never read)."""
    from spl_al.experiment import embedding_steps

    real = embedding_steps.probe_inputs
    leaked = {}

    def leaking(probe, embeddings, needs, **kw):
        inputs = real(probe, embeddings, needs, **kw)
        hidden = leaked["labels"][inputs.unlabeled_idx]
        for name in ("features", "group_features"):
            if getattr(inputs, name) is not None:
                setattr(inputs, name, (getattr(inputs, name) + 10.0 * hidden[:, None]))
        if inputs.margin is not None:
            inputs.margin = inputs.margin + hidden
        return inputs

    real_run = embedding_steps._run

    def run(facts, *args, **kw):
        leaked["labels"] = facts.train_labels
        return real_run(facts, *args, **kw)

    monkeypatch.setattr(embedding_steps, "probe_inputs", leaking)
    monkeypatch.setattr(embedding_steps, "_run", run)
    for strategy in ("margin", "coreset"):
        with pytest.raises(AssertionError):
            _assert_hidden_labels_unread(strategy)


def test_probe_runs_write_records_the_report_reads(tmp_path):
    path, _ = _dataset(tmp_path)
    out, _ = _encode(tmp_path, path, "enc")
    runs = tmp_path / "duis.json"
    method = {"strategy": "duis", "params": {"n_cand": 6}, "use_variants": True}
    spec = ProbeRuns("toy", "duis", method, VARIANTS, AL, seeds=(1, 2), rounds=3, encoders=(0, 0))
    kwargs = dict(runs=spec, out_path=runs)
    records = probe_runs(path, _files(out), **kwargs)
    assert [(r["seed"], r["round"], r["n_labeled"]) for r in records] == [
        (s, r, 6 + 3 * r) for s in (1, 2) for r in range(3)
    ]
    assert records[0]["train_images"] == 6 * 3  # observed + both variants
    again = tmp_path / "again.json"
    probe_runs(path, _files(out), **{**kwargs, "out_path": again})

    def timeless(path):
        return [
            {k: v for k, v in r.items() if not k.endswith("seconds")}
            for r in json.loads(path.read_text())
        ]

    assert timeless(runs) == timeless(again)  # the same labeled sets and values
    df = load_records([runs])
    assert set(df["framework"]) == {"embedding"} and set(df["precision"]) == {"fp32"}
    # the round-0 set is the seed's supervised one
    from spl_al.pool import initial_labeled_set

    first = json.loads(runs.read_text())[0]
    assert sorted(first["pool_indices"]) == initial_labeled_set(N_TRAIN, 6, 1).tolist()
    with pytest.raises(ValueError, match="trained with dataset 'toy'"):
        probe_runs(path, _files(out), **{**kwargs, "runs": replace(spec, dataset="other")})
    # N_cand over half the unlabeled pool: the supervised query's sentence, naming the run
    big = {**method, "params": {"n_cand": 12}}
    with pytest.raises(ValueError, match=r"toy/duis seed 1.*makes round 1.*n_cand"):
        probe_runs(path, _files(out), **{**kwargs, "runs": replace(spec, method=big)})


def test_a_table_refuses_two_frameworks(tmp_path):
    base = {
        "dataset": "d",
        "method": "random",
        "seed": 1,
        "n_labeled": 5,
        "n_total": 10,
        "metric": "accuracy",
        "value": 0.5,
        "synthetic_standin": False,
    }
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps([{**base, "round": 0, "framework": "embedding"}]))
    b.write_text(json.dumps({**base, "round": 1}))
    with pytest.raises(ValueError, match="mixes rounds of different frameworks"):
        load_records([a, b])


def test_the_probe_bench_encoder_reads_no_validation_image(tmp_path):
    """bench probe tunes on the validation split: its encoder learns from the fit part
    alone, so other validation images leave the fit part's embeddings as they were."""
    from spl_al.bench.learnability import tuning_split
    from spl_al.bench.probe import encode_fit_part

    _, data = _dataset(tmp_path)
    fit_idx, val_idx = tuning_split(data)
    quiet = {"log": lambda _line: None}
    first, _ = encode_fit_part(data, fit_idx, ENCODER, **quiet)
    data.depth_m[val_idx] += 2.0
    second, _ = encode_fit_part(data, fit_idx, ENCODER, **quiet)
    np.testing.assert_array_equal(first[fit_idx], second[fit_idx])
    assert not np.array_equal(first[val_idx, 0], second[val_idx, 0])


def test_dense_embeddings_give_every_pixel_each_stage_of_the_encoder(tmp_path):
    from spl_al.bench.probe import dense_embeddings
    from spl_al.training.contrastive import Encoder

    _, data = _dataset(tmp_path)
    encoder = Encoder(EncoderConfig.from_dict(ENCODER)).eval()
    dense = dense_embeddings(encoder, data.depth_m[:5], data.valid[:5])
    h, w = data.depth_m.shape[1:]
    assert dense.shape == (5, h, w, 4 + 8 + 16 + 32)  # width 4, four stages
    assert np.isfinite(dense).all()


def test_an_encoder_card_records_where_it_trained_and_its_health(tmp_path):
    path, _ = _dataset(tmp_path)
    out, card = _encode(tmp_path, path, "a")
    import hashlib

    assert card["weights_sha256"] == hashlib.sha256(out["encoder"].read_bytes()).hexdigest()
    trained = card["trained_with"]
    assert trained["precision"] == "fp32" and trained["device"] and trained["threads"] >= 1
    assert trained["torch"].split(".")[0].isdigit()
    import torch

    assert trained["cpu_capability"] == torch.backends.cpu.get_cpu_capability()
    health = card["health"]
    assert set(health) == {"loss_ratio", "effective_rank", "verdict", "failed"}
    assert health["loss_ratio"] == pytest.approx(card["final_loss"] / card["chance_loss"], 1e-3)


def test_a_collapsed_encoder_is_refused_naming_its_dataset_seed_and_figure(tmp_path):
    path, _ = _dataset(tmp_path)
    # one step at a vanishing learning rate: the loss stays at chance
    collapsed = {**ENCODER, "steps": 1, "lr": 1e-9, "seed": 7}
    out = {k: tmp_path / f"c.{k}" for k in ("encoder", "card", "embeddings")}
    with pytest.raises(ValueError, match=r"toy: the encoder of seed 7 collapsed: final loss") as e:
        train_encoder(path, dataset="toy", encoder=collapsed, variants=VARIANTS, out=out)
    assert str(e.value).count(". ") == 0
    assert not any(p.exists() for p in out.values())  # nothing written


def test_encoder_health_flags_a_near_collapse_and_a_rank_collapse():
    from spl_al.training.contrastive import chance_loss, effective_rank, encoder_health

    rng = np.random.default_rng(0)
    spread = rng.normal(size=(200, 32))
    assert chance_loss(128) == pytest.approx(np.log(255))
    # the case: NT-Xent 4.30 at 128 frames a batch, chance 5.54
    doubtful = encoder_health({"final_loss": 4.30, "chance_loss": chance_loss(128)}, spread)
    assert (
        doubtful["verdict"] == "doubtful" and "final loss 0.78 of chance" in doubtful["failed"][0]
    )
    line = np.outer(rng.normal(size=200), rng.normal(size=32))  # every sample on one line
    assert effective_rank(line) == pytest.approx(1.0, abs=1e-6)
    flat = encoder_health({"final_loss": 1.0, "chance_loss": 5.0}, line)
    assert flat["verdict"] == "collapsed" and "effective rank 1.0" in flat["failed"][0]
    good = encoder_health({"final_loss": 2.0, "chance_loss": 5.54}, spread)
    assert good["verdict"] == "healthy" and good["failed"] == []


def test_generic_views_keep_voids_and_differ_from_the_siv_pair():
    import torch

    from spl_al.training.contrastive import _generic_views

    x = torch.zeros(4, 3, 2, 16, 16)
    x[:, :, 1, 4:12, 4:12] = 1.0  # valid square
    x[:, :, 0] = x[:, :, 1] * 0.5
    gen = torch.Generator().manual_seed(0)
    cfg = EncoderConfig(objective="generic", pixel_dropout=0.2)
    v = _generic_views(x, torch.arange(4), gen, cfg)
    assert v.shape == (8, 2, 16, 16)
    assert set(v[:, 1].unique().tolist()) <= {0.0, 1.0}
    assert torch.all(v[:, 0][v[:, 1] == 0] == 0)  # a void has no depth
    assert not torch.equal(v[:4], v[4:])  # two different augmentations of each frame
    with pytest.raises(ValueError, match="objective must be one of"):
        EncoderConfig.from_dict({"objective": "simclr"})


def test_run_seeds_read_their_block_s_encoder(tmp_path):
    path, _ = _dataset(tmp_path)
    a, _ = _encode(tmp_path, path, "e3", {**ENCODER, "seed": 3})
    b, _ = _encode(tmp_path, path, "e5", {**ENCODER, "seed": 5})
    files = {**_files(a, 3), **_files(b, 5)}
    method = {"strategy": "random", "params": {}, "use_variants": False}
    spec = ProbeRuns(
        "toy", "random", method, VARIANTS, AL, seeds=(1, 2, 3), rounds=2, encoders=(3, 3, 5)
    )
    records = probe_runs(path, files, runs=spec, out_path=tmp_path / "r.json")
    assert [(r["seed"], r["encoder"]) for r in records if r["round"] == 0] == [
        (1, 3),
        (2, 3),
        (3, 5),
    ]
    df = load_records([tmp_path / "r.json"])
    assert sorted(df["encoder"].unique()) == [3, 5]
    # a block whose encoder's card is another seed's: refused, naming both
    swapped = {3: files[5], 5: files[3]}
    with pytest.raises(
        ValueError, match="trained with seed 5, but these run seeds read encoder seed 3"
    ):
        probe_runs(path, swapped, runs=spec, out_path=tmp_path / "s.json")


def test_each_round_records_what_the_strategy_decided():
    """ProbCover's radius, purity and coverage and TypiClust's clusters reach every
    query's record; the embedding is fixed, so ProbCover's radius is one per run."""
    from spl_al.experiment.embedding_steps import _run
    from spl_al.experiment.plan import MethodSpec

    facts = _facts(np.random.default_rng(1), np.random.default_rng(0).integers(0, 4, 60))
    al = {"initial": 10, "batch": 5}
    spec = MethodSpec(name="probcover", strategy="probcover", params={"n_classes": 4})
    records = _run(facts, spec, which=("toy", 1), al=al, rounds=4, probe={"c": 1.0}, n_variants=2)
    decided = [r["query_decision"] for r in records[:-1]]
    assert len(decided) == 3 and "query_decision" not in records[-1]  # no query after
    assert len({d["delta"] for d in decided}) == 1 and all(d["purity"] >= 0.95 for d in decided)
    assert all(d["coverage_before"] <= d["coverage_after"] for d in decided)
    spec = MethodSpec(name="typiclust", strategy="typiclust")
    records = _run(facts, spec, which=("toy", 1), al=al, rounds=2, probe={"c": 1.0}, n_variants=2)
    assert records[0]["query_decision"]["clusters"] == 15  # 10 labeled + a batch of 5


def test_the_probe_bench_trains_the_configs_encoder_recipe():
    """bench probe reads a config whose encoder block plans several encoders (seeds,
    block): it trains the shared recipe at the first seed (it stopped with "unknown keys
    ['block', 'seeds']")."""
    from pathlib import Path

    import yaml

    from spl_al.bench.probe import probe_encoder
    from spl_al.training.contrastive import EncoderConfig

    default = Path(__file__).resolve().parents[1] / "config" / "config.yaml"
    config = yaml.safe_load(default.read_text())
    for name in ("real_cls", "synth_cls"):
        settings = probe_encoder(config["datasets"][name])
        assert "seeds" not in settings and "block" not in settings
        cfg = EncoderConfig.from_dict(settings)
        assert cfg.seed == 0 and cfg.steps == settings["steps"]


def test_one_thread_reaches_the_libraries_a_round_loads_later():
    """A probe-runs job limits scipy's own OpenBLAS and scikit-learn's OpenMP too, not
    only the pools loaded before its limit: in a fresh interpreter, every pool a fit and
    a k-means use has one thread inside ``one_thread``."""
    import subprocess
    import sys

    code = (
        "import numpy, threadpoolctl\n"
        "from spl_al.blas_threads import one_thread\n"
        "with one_thread():\n"
        "    from sklearn.linear_model import LogisticRegression\n"
        "    LogisticRegression().fit(numpy.eye(4), [0, 1, 0, 1])\n"
        "    pools = threadpoolctl.threadpool_info()\n"
        "print(len(pools), max(p['num_threads'] for p in pools))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    n_pools, most = map(int, out.stdout.split())
    assert n_pools >= 2 and most == 1


def test_shared_runs_relabel_the_sources_runs_only_over_the_same_scans(tmp_path):
    """embedding: {shared: SOURCE}: a dataset of the same scans takes the source's
    records under its own name; another dataset's file is refused, nothing written."""
    from spl_al.atomic import write_json
    from spl_al.experiment.embedding_steps import shared_runs

    source, _ = _dataset(tmp_path, name="source.npz")
    same, _ = _dataset(tmp_path, name="same.npz")
    runs = tmp_path / "source_runs.json"
    write_json([{"dataset": "src", "seed": 1, "round": 0, "value": 0.5}], runs)
    out = tmp_path / "runs.json"
    shared_runs(runs, same, source, dataset="pc", source="src", out_path=out)
    assert json.loads(out.read_text()) == [
        {"dataset": "pc", "seed": 1, "round": 0, "value": 0.5, "runs_of": "src"}
    ]
    depth, _, _ = shapes_groups(30, n_groups=3, seed=1)
    other, _ = _dataset(tmp_path, test_depth=depth[N_TRAIN:, 0] + 1.0, name="other.npz")
    refused = tmp_path / "refused.json"
    with pytest.raises(ValueError, match=r"its 'depth' is not src's .* cannot share src's"):
        shared_runs(runs, other, source, dataset="pc", source="src", out_path=refused)
    assert not refused.exists()

"""The embedding framework: the self-supervised encoder learns without labels or test
images, its card refuses another dataset, and a round on frozen embeddings keeps the
strategy contract (never a label of an unlabeled group)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from al_synthetic import shapes_groups

from spl_al.data import Dataset
from spl_al.experiment.embedding_steps import check_card, probe_runs, train_encoder
from spl_al.experiment.step_args import ProbeRuns
from spl_al.linear_probe import LinearProbe, probe_inputs
from spl_al.report import load_records
from spl_al.strategies import check_picks, get, names
from spl_al.training.contrastive import EncoderConfig, nt_xent

ENCODER = {"width": 4, "steps": 6, "batch_size": 8, "projection_dim": 8, "input_pool": 1}
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


def _encode(tmp_path, data_path, stem):
    out = {k: tmp_path / f"{stem}.{k}" for k in ("encoder", "card", "embeddings")}
    card = train_encoder(data_path, dataset="toy", encoder=ENCODER, variants=VARIANTS, out=out)
    return out, card


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


@pytest.mark.parametrize("strategy", sorted(set(names()) - {"skactiveml"}))
def test_embedding_round_keeps_the_strategy_contract(strategy):
    """Picks are distinct unlabeled groups, seeded, and the same whatever the hidden
    labels of the unlabeled groups (the probe reads the labeled groups' alone)."""
    rng = np.random.default_rng(0)
    emb = rng.normal(size=(60, 3, 8)).astype(np.float32)
    labels = rng.integers(0, 4, 60)
    labeled = np.arange(0, 60, 6)
    unlabeled = np.setdiff1d(np.arange(60), labeled)
    params = {"n_classes": 4} if strategy == "probcover" else {}
    if strategy in ("duis", "diversity"):
        params["n_cand"] = 12
    s = get(strategy, **params)

    def picks(hidden):
        probe = LinearProbe(4).fit(emb[labeled, 0], hidden[labeled])
        inputs = probe_inputs(
            probe, emb, s.needs, unlabeled_idx=unlabeled, labeled_idx=labeled, n_images=3
        )
        return check_picks(strategy, s.select(inputs, 5, np.random.default_rng(1)), inputs, 5)

    first = picks(labels)
    other = labels.copy()
    other[unlabeled] = rng.permutation(other[unlabeled])
    np.testing.assert_array_equal(first, picks(other))
    np.testing.assert_array_equal(first, picks(labels))
    assert not np.isin(first, labeled).any() and len(set(first.tolist())) == 5


def test_probe_runs_write_records_the_report_reads(tmp_path):
    path, _ = _dataset(tmp_path)
    out, _ = _encode(tmp_path, path, "enc")
    runs = tmp_path / "duis.json"
    method = {"strategy": "duis", "params": {"n_cand": 6}, "use_variants": True}
    spec = ProbeRuns("toy", "duis", method, VARIANTS, AL, seeds=(1, 2), rounds=3)
    kwargs = dict(runs=spec, out_path=runs)
    records = probe_runs(path, out["embeddings"], out["card"], **kwargs)
    assert [(r["seed"], r["round"], r["n_labeled"]) for r in records] == [
        (s, r, 6 + 3 * r) for s in (1, 2) for r in range(3)
    ]
    assert records[0]["train_images"] == 6 * 3  # observed + both variants
    again = tmp_path / "again.json"
    probe_runs(path, out["embeddings"], out["card"], **{**kwargs, "out_path": again})

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
        probe_runs(
            path,
            out["embeddings"],
            out["card"],
            **{**kwargs, "runs": replace(spec, dataset="other")},
        )
    # N_cand over half the unlabeled pool: the supervised query's sentence, naming the run
    big = {**method, "params": {"n_cand": 12}}
    with pytest.raises(ValueError, match=r"toy/duis seed 1.*makes round 1.*n_cand"):
        probe_runs(
            path, out["embeddings"], out["card"], **{**kwargs, "runs": replace(spec, method=big)}
        )


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

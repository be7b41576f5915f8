"""Budget points and candidate pools of a config: per-round batches (``al.batch`` as a
list), the street datasets' five budget points, and N_cand at most half the unlabeled
pool at every query, checked when the config parses and again at the query."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from spl_al.config import check_config
from spl_al.experiment.plan import (
    batch_of,
    check_plan,
    dataset_method,
    dataset_runs,
    labeled_at,
    train_pool_size,
)
from spl_al.experiment.round0 import write_initial_set
from spl_al.experiment.round_steps import query_round
from spl_al.strategies import StrategyInputs
from spl_al.strategies.duis import CandidatePoolTooLarge

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = ROOT / "config" / "schema.yaml"


@pytest.fixture(scope="module")
def default():
    return yaml.safe_load((ROOT / "config" / "config.yaml").read_text())


@pytest.mark.parametrize("dataset", ["street_seg", "street_pc"])
def test_street_datasets_plan_the_papers_five_budget_points(default, dataset):
    entry = default["datasets"][dataset]
    assert train_pool_size(entry) == 210
    rounds = set(dataset_runs(default, dataset).values())
    assert rounds == {5}
    counts = [labeled_at(entry["al"], r) for r in range(5)]
    assert counts == [6, 12, 18, 27, 36]
    assert [round(100 * n / 210, 1) for n in counts] == [2.9, 5.7, 8.6, 12.9, 17.1]
    assert [batch_of(entry["al"], r) for r in range(1, 5)] == [6, 6, 9, 9]
    # the per-level point is the paper's 12.9%
    assert labeled_at(entry["al"], entry["experiments"]["levels"]["round"]) == 27


def test_n_cand_is_at_most_half_the_pool_at_every_query_of_the_default_run(default):
    check_plan(default)
    for dataset, entry in default["datasets"].items():
        n_train = train_pool_size(entry)
        for (method, _seed), rounds in dataset_runs(default, dataset).items():
            n_cand = dataset_method(default, dataset, method).params.get("n_cand")
            if n_cand is None:
                continue
            for r in range(1, rounds):
                assert n_cand <= (n_train - labeled_at(entry["al"], r - 1)) / 2, (dataset, method)
    for dataset in ("street_seg", "street_pc"):
        for method in ("duis", "syn_diversity"):
            assert dataset_method(default, dataset, method).params["n_cand"] == 80


def test_a_batch_list_needs_one_batch_per_query(default):
    config = copy.deepcopy(default)
    al = config["datasets"]["street_seg"]["al"]
    for batch, queries in (([6, 6, 9], 3), ([6, 6, 9, 9, 9], 5)):
        al["batch"] = batch
        with pytest.raises(ValueError) as err:
            check_plan(config)
        message = str(err.value)
        assert message.startswith("config key 'datasets.street_seg.al.batch' lists ")
        assert f"lists {queries} per-round batches but the dataset's experiments make 4" in message
        assert message.count(". ") == 0 and message.endswith(".")
    # fewer rounds with a list that matches them is fine (the supervised framework alone)
    config["datasets"]["street_seg"].pop("embedding")
    al["batch"] = [6, 6]
    config["datasets"]["street_seg"]["experiments"]["budget"]["rounds"] = 3
    config["datasets"]["street_seg"]["experiments"]["levels"]["round"] = 2
    check_plan(config)


@pytest.mark.parametrize(
    ("batch", "where", "words"),
    [
        ([6, 0, 9, 9], r"batch\.1", "0 is less than the minimum of 1"),
        ([], "batch", r"\[\] should be non-empty"),
        ("six", "batch", "'six' is not integer >= 1, or list of integer >= 1"),
    ],
)
def test_the_schema_takes_an_integer_or_a_list_of_positive_integers(default, batch, where, words):
    """A bad batch is named with what is wrong with it (the entry of a list, the
    alternatives the key takes), not "not valid under any of the given schemas"."""
    config = copy.deepcopy(default)
    check_config(config, SCHEMA)
    config["datasets"]["street_pc"]["al"]["batch"] = batch
    with pytest.raises(ValueError, match=rf"'datasets\.street_pc\.al\.{where}': {words} "):
        check_config(config, SCHEMA)


def test_batch_of_a_list_and_past_its_end():
    al = {"initial": 6, "batch": [6, 6, 9, 9]}
    assert [labeled_at(al, r) for r in range(5)] == [6, 12, 18, 27, 36]
    assert batch_of({"initial": 4, "batch": 32}, 7) == 32
    with pytest.raises(ValueError, match=r"'datasets\.x\.al\.batch' lists 4 .* round 5"):
        batch_of(al, 5, "datasets.x.al.batch")
    assert batch_of(al, 5, past_end=True) == 9  # a human oracle's extra rounds
    with pytest.raises(ValueError, match="round 0"):
        batch_of(al, 0)


def test_n_cand_above_half_a_pool_is_refused_when_the_config_parses(default):
    config = copy.deepcopy(default)
    # the old street setting: N_cand 160 of 206 unlabeled scans at the first query (the
    # supervised framework's DUIS; the embedding framework's would add Syn+Diversity)
    config["datasets"]["street_seg"].pop("embedding")
    config["datasets"]["street_seg"].pop("method_params")
    with pytest.raises(ValueError) as err:
        check_plan(config)
    assert str(err.value) == (
        "street_seg/duis: the query that makes round 1 draws a k-means candidate pool of "
        "N_cand = 160 from 204 unlabeled groups (78%, more than half of them: no longer a "
        "diverse subset); set datasets.street_seg.method_params.duis.n_cand <= 102."
    )
    # 92 passes the first queries and fails only the last one (183 unlabeled scans)
    config["datasets"]["street_seg"]["method_params"] = {"duis": {"n_cand": 92}}
    with pytest.raises(ValueError, match=r"makes round 4 .* N_cand = 92 from 183 .* <= 91\."):
        check_plan(config)
    config["datasets"]["street_seg"]["method_params"] = {"duis": {"n_cand": 91}}
    check_plan(config)


def test_a_swept_n_cand_above_half_names_the_sweep(default):
    config = copy.deepcopy(default)
    config["sweeps"]["n_cand"] = [40, 400]
    with pytest.raises(ValueError, match=r"real_cls/duis_ncand400: .* set the 'sweeps.n_cand'"):
        check_plan(config)


def test_pool_sizes_are_left_to_the_query_where_the_data_fixes_them(default):
    entry = {**default["datasets"]["real_cls"], "path": "/somewhere", "standin": False}
    assert train_pool_size(entry) is None
    assert train_pool_size(default["datasets"]["real_cls"]) == 770  # 11 x 70 stand-in


def _scores(tmp_path, n_train=40, labeled=6):
    rng = np.random.default_rng(0)
    labeled_idx = np.arange(labeled)
    unlabeled_idx = np.arange(labeled, n_train)
    n = unlabeled_idx.size
    StrategyInputs(
        unlabeled_idx,
        labeled_idx,
        group_features=rng.normal(size=(n, 3)),
        gamma=rng.uniform(size=n),
        inconsistency=rng.uniform(size=n),
    ).save(tmp_path / "scores.npz")
    write_initial_set(labeled_idx, 1, tmp_path / "labeled.json")
    return tmp_path / "scores.npz", tmp_path / "labeled.json"


def _query(scores, labeled, method, out_path, seed=1, round_=1, **names):
    """``query_round`` of a batch of 6 (``names``: the dataset and method it reports)."""
    return query_round(
        scores,
        labeled,
        method=method,
        batch=6,
        seed=seed,
        round_=round_,
        out_path=out_path,
        **names,
    )


def test_the_query_records_n_cand_and_the_pool_it_drew_from(tmp_path):
    scores, labeled = _scores(tmp_path)
    method = {"strategy": "duis", "params": {"n_cand": 17}}
    record = _query(scores, labeled, method, tmp_path / "q.json", dataset="toy", method_name="duis")
    saved = json.loads((tmp_path / "q.json").read_text())
    assert saved == record
    assert (saved["n_cand"], saved["n_unlabeled"], saved["batch"]) == (17, 34, 6)
    assert saved["cand_ratio"] == pytest.approx(0.5)
    plain = _query(scores, labeled, {"strategy": "random"}, tmp_path / "m.json")
    assert (plain["n_cand"], plain["n_unlabeled"], plain["cand_ratio"]) == (None, 34, None)


def test_the_query_refuses_n_cand_above_half_naming_the_round(tmp_path):
    scores, labeled = _scores(tmp_path)
    method = {"strategy": "diversity", "params": {"n_cand": 18}}
    with pytest.raises(CandidatePoolTooLarge) as err:
        _query(
            scores, labeled, method, tmp_path / "q.json", seed=2, round_=3, dataset="toy",
            method_name="syn_div",
        )  # fmt: skip
    assert str(err.value) == (
        "toy/syn_div seed 2: the query that makes round 3 draws a k-means candidate pool of "
        "N_cand = 18 from 34 unlabeled groups (53%, more than half of them: no longer a "
        "diverse subset); set datasets.toy.method_params.syn_div.n_cand <= 17."
    )
    assert not (tmp_path / "q.json").exists()

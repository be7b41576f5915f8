"""scikit-activeml's low-budget strategies through the adapter: the picks are the
library's own, they know which samples are labeled and nothing else, and a class the
adapter cannot feed is refused when the config is read."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from spl_al import strategies
from spl_al.config import check_config
from spl_al.experiment.plan import budget_families, check_plan, method_specs
from spl_al.strategies import StrategyInputs
from spl_al.strategies.skactiveml_adapter import adapter_data, query_seed

pool = pytest.importorskip("skactiveml.pool")

ROOT = Path(__file__).resolve().parents[1]
# registered name -> (scikit-activeml class, parameters of both calls)
# (TypiClust and ProbCover are spl-al's own now: tests/test_lowbudget.py)
NAMED = {"maxherding": ("MaxHerding", {})}
# what the adapter passes scikit-activeml for each: MaxHerding with its paper's kernel
DIRECT = {"maxherding": {"normalize_samples": True, "metric": "rbf", "metric_dict": {"gamma": 1.0}}}


def _inputs(n_unl=300, n_lab=12, d=16, seed=0):
    """Features with cluster structure (5 blobs), labeled rows among them."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(0, 1.0, (5, d))
    x = centres[rng.integers(0, 5, n_unl + n_lab)] + rng.normal(0, 0.25, (n_unl + n_lab, d))
    order = rng.permutation(n_unl + n_lab)
    return StrategyInputs(
        unlabeled_idx=np.sort(order[:n_unl]),
        labeled_idx=order[n_unl:],
        features=x[:n_unl].astype(np.float32),
        labeled_features=x[n_unl:].astype(np.float32),
    )


def _direct(cls_name, params, inputs, k, random_state, y_labeled=None):
    """scikit-activeml called by hand on the same features: labeled rows first (with
    ``y_labeled`` as their classes, default one placeholder class), unlabeled after."""
    x = np.concatenate([inputs.labeled_features, inputs.features]).astype(np.float64)
    y = np.full(len(x), np.nan)
    n_lab = len(inputs.labeled_idx)
    y[:n_lab] = 0 if y_labeled is None else y_labeled
    qs = getattr(pool, cls_name)(**params, random_state=random_state)
    rows = qs.query(x, y, batch_size=k)
    return inputs.unlabeled_idx[np.asarray(rows) - n_lab]


@pytest.mark.parametrize("name", sorted(NAMED))
@pytest.mark.parametrize("k", [1, 10, 40])
def test_picks_equal_scikit_activemls_direct_call(name, k):
    cls_name, params = NAMED[name]
    inputs = _inputs()
    ours = strategies.get(name, **params).select(inputs, k, np.random.default_rng(7))
    seed = query_seed(np.random.default_rng(7))  # the seed the adapter passed on
    assert ours.tolist() == _direct(cls_name, DIRECT[name], inputs, k, seed).tolist()
    # the generic form {skactiveml: CLASS, ...} with the same parameters is the same
    generic = strategies.get("skactiveml", cls=cls_name, **DIRECT[name])
    assert generic.select(inputs, k, np.random.default_rng(7)).tolist() == ours.tolist()


@pytest.mark.parametrize("name", sorted(NAMED))
def test_picks_do_not_change_when_the_labeled_rows_classes_are_permuted(name):
    """With the labeled rows' real classes, those classes permuted, or the adapter's
    placeholder, scikit-activeml picks the same samples: the strategies use which rows
    are labeled, not their labels, so the adapter (which has no labels) loses nothing."""
    cls_name, params = NAMED[name]
    inputs = _inputs()
    n_lab = len(inputs.labeled_idx)
    classes = np.arange(n_lab) % 5  # every one of the 5 classes present
    rng = np.random.default_rng(3)
    seed = 12345
    real = _direct(cls_name, params, inputs, 15, seed, y_labeled=classes)
    for _ in range(3):
        shuffled = _direct(cls_name, params, inputs, 15, seed, y_labeled=rng.permutation(classes))
        assert shuffled.tolist() == real.tolist()
    assert _direct(cls_name, params, inputs, 15, seed).tolist() == real.tolist()
    # the adapter's y: placeholder 0 for labeled rows, missing for the rest, no label
    _, y = adapter_data(inputs)
    assert (y[:n_lab] == 0).all() and np.isnan(y[n_lab:]).all()


def test_seed_passes_through_as_random_state():
    inputs = _inputs()
    s = strategies.get("skactiveml", cls="TypiClust")
    a = s.select(inputs, 10, np.random.default_rng(1))
    assert a.tolist() == s.select(inputs, 10, np.random.default_rng(1)).tolist()
    seeds = {query_seed(np.random.default_rng(r)) for r in range(5)}
    assert len(seeds) == 5


def test_a_repeated_pick_is_completed_not_passed_on():
    """TypiClust 1.0.1 may repeat a sample when k-means finds fewer clusters than the
    batch (identical features): the adapter keeps the first occurrences and draws
    the rest from the unpicked unlabeled groups."""
    inputs = StrategyInputs(
        unlabeled_idx=np.arange(20),
        labeled_idx=np.arange(20, 23),
        features=np.ones((20, 4), np.float32),
        labeled_features=np.ones((3, 4), np.float32),
    )
    typiclust = strategies.get("skactiveml", cls="TypiClust")
    picks = typiclust.select(inputs, 12, np.random.default_rng(0))
    assert len(set(picks.tolist())) == 12 and set(picks.tolist()) <= set(range(20))


def _config(**methods):
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config["methods"].update(methods)
    return config


@pytest.mark.parametrize(
    ("entry", "words"),
    [
        ({"skactiveml": "Badge"}, ["Badge needs clf", "never a label"]),
        ({"skactiveml": "Falcun"}, ["Falcun needs clf"]),
        ({"skactiveml": "QueryByCommittee"}, ["QueryByCommittee needs ensemble"]),
        ({"skactiveml": "StreamRandomSampling"}, ["StreamRandomSampling is a stream strategy"]),
        ({"skactiveml": "NoSuchThing"}, ["no single-annotator pool strategy 'NoSuchThing'"]),
        ({"skactiveml": "TypiClust", "params": {"kk": 1}}, ["unexpected parameters ['kk']"]),
        ({"skactiveml": "TypiClust", "params": {"random_state": 1}}, ["set by the adapter"]),
    ],
)
def test_unsupported_classes_fail_when_the_config_is_read(entry, words):
    config = _config(mine=entry)
    config["datasets"]["real_cls"]["experiments"]["budget"]["methods"].append("mine")
    check_config(config, ROOT / "config" / "schema.yaml")
    with pytest.raises(ValueError) as err:
        check_plan(config)
    message = str(err.value)
    assert message.startswith("config key 'methods.mine': ")
    assert all(w in message for w in words), message
    assert message.endswith(".") and message.count(". ") == 0, message


def test_config_runs_them_in_both_families_without_changing_the_default():
    config = _config()
    check_config(config, ROOT / "config" / "schema.yaml")
    check_plan(config)  # named, run by no default experiment
    for name in ("typiclust", "probcover", "maxherding"):
        assert name not in config["datasets"]["real_cls"]["experiments"]["budget"]["methods"]
    budget = config["datasets"]["real_cls"]["experiments"]["budget"]
    budget["methods"] = ["random", "typiclust", "probcover", "maxherding", "duis"]
    config["methods"]["mine"] = {"skactiveml": "MaxHerding", "params": {"metric": "linear"}}
    budget["methods"].insert(-1, "mine")
    check_plan(config)
    specs = method_specs(config)
    families = budget_families(config, "real_cls", specs)
    assert families["paper"] == ["random", "typiclust", "probcover", "maxherding", "mine", "duis"]
    assert families["matched"][:4] == [
        "syn_random", "syn_typiclust", "syn_probcover", "syn_maxherding"
    ]  # fmt: skip
    assert specs["syn_probcover"].params == {"n_classes": 11}
    assert specs["syn_probcover"].use_variants
    assert specs["syn_mine"].strategy == "skactiveml"
    assert specs["syn_mine"].params == {"cls": "MaxHerding", "metric": "linear"}


def test_importing_the_strategies_imports_no_scikit_activeml():
    code = (
        "import sys, spl_al.strategies as s; s.get('maxherding');"
        "assert 'skactiveml' in sys.modules;"
        "del sys.modules['skactiveml']"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
    subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys, spl_al.strategies; assert 'skactiveml' not in sys.modules",
        ],
        check=True,
    )

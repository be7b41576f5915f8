"""Strategies from anywhere: a distribution's ``spl_al.strategies`` entry point on
``sys.path`` registers a strategy, which keeps the shared contract and runs through
the CI DAG; a strategy that breaks the contract stops the round in one sentence."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from helpers.snakemake_cli import CI_CONFIG, SNAKEMAKE
from test_strategies import check_contract, make_inputs

from spl_al import strategies
from spl_al.experiment.plan import check_plan
from spl_al.experiment.round_steps import query_round
from spl_al.strategies import StrategyContractError, StrategyInputs

ROOT = Path(__file__).resolve().parents[1]

# a strategy that breaks the contract in the query step: it overrides select itself
BROKEN = """
import numpy as np
from spl_al.strategies import Strategy


class Broken(Strategy):
    def __init__(self, mode="labeled"):
        self.mode = mode

    def select(self, inputs, budget, rng):
        u = inputs.unlabeled_idx
        if self.mode == "labeled":
            return np.r_[inputs.labeled_idx[:1], u[: budget - 1]]
        if self.mode == "repeat":
            return np.r_[u[:1], u[: budget - 1]]
        return u[: budget + 1]
"""


def docs_example() -> str:
    """The strategy module of docs/library.md's example, as written there."""
    text = (ROOT / "docs" / "library.md").read_text()
    block = text.split("<!-- plugin-example -->", 1)[1]
    return re.search(r"```python\n(.*?)```", block, re.S).group(1)


def make_distribution(root: Path, name: str, modules: dict[str, str], entries: dict) -> Path:
    """A distribution as an installed one looks on ``sys.path``: its modules and a
    ``NAME-0.1.dist-info`` with METADATA and entry_points.txt."""
    root.mkdir(parents=True, exist_ok=True)
    for module, source in modules.items():
        (root / f"{module}.py").write_text(source)
    info = root / f"{name}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    lines = [f"{k} = {v}" for k, v in entries.items()]
    (info / "entry_points.txt").write_text("[spl_al.strategies]\n" + "\n".join(lines) + "\n")
    return root


@pytest.fixture(scope="module")
def plugin_dir(tmp_path_factory):
    return make_distribution(
        tmp_path_factory.mktemp("site"),
        "my_strategies",
        {"my_strategies": docs_example(), "broken_strategy": BROKEN},
        {"farthest": "my_strategies:FarthestFromLabeled", "broken": "broken_strategy:Broken"},
    )


@pytest.fixture
def on_path(plugin_dir, monkeypatch):
    monkeypatch.syspath_prepend(str(plugin_dir))
    strategies.load_entry_points(force=True)
    return plugin_dir


def test_the_docs_example_is_thirty_lines():
    assert len(docs_example().strip().splitlines()) <= 30


def test_an_entry_point_is_a_strategy_name(on_path):
    assert {"farthest", "broken"} <= set(strategies.names())
    assert "farthest" not in strategies.base.builtin_names()
    s = strategies.get("farthest", jitter=1e-5)
    assert s.name == "farthest" and s.params() == {"jitter": 1e-5}
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config["methods"]["far"] = {"strategy": "farthest"}
    config["datasets"]["real_cls"]["experiments"]["budget"]["methods"].insert(0, "far")
    check_plan(config)  # the config takes it (and its syn_far twin)


@pytest.mark.parametrize("kind", ["random", "identical", "one_class"])
@pytest.mark.parametrize("dense", [False, True], ids=["cls", "seg"])
def test_an_entry_point_strategy_keeps_the_shared_contract(on_path, kind, dense):
    check_contract("farthest", {}, make_inputs(kind=kind, dense=dense))


def test_the_example_picks_the_farthest_groups(on_path):
    inputs = StrategyInputs(
        unlabeled_idx=[0, 1, 2, 3],
        labeled_idx=[4],
        features=np.array([[1.0], [5.0], [-3.0], [0.5]]),
        labeled_features=np.array([[0.0]]),
    )
    picks = strategies.get("farthest").select(inputs, 3, np.random.default_rng(0))
    assert picks.tolist() == [1, 2, 0]


def _query_files(tmp_path):
    inputs = make_inputs(n_unl=20, n_lab=5)
    inputs.save(tmp_path / "scores.npz")
    labeled = tmp_path / "labeled.json"
    labeled.write_text(json.dumps({"pool_indices": inputs.labeled_idx.tolist()}))
    return inputs, tmp_path / "scores.npz", labeled


@pytest.mark.parametrize(
    ("mode", "what"),
    [
        ("labeled", "the labeled groups [{lab}]"),
        ("repeat", "the repeated indices [{unl}]"),
        ("count", "5 indices for a batch of 4"),
    ],
)
def test_a_broken_pick_stops_the_round_in_one_sentence(on_path, tmp_path, mode, what):
    inputs, scores, labeled = _query_files(tmp_path)
    out = tmp_path / "round1" / "labeled.json"
    method = {"strategy": "broken", "params": {"mode": mode}}
    with pytest.raises(StrategyContractError) as err:
        query_round(
            scores,
            labeled,
            method=method,
            batch=4,
            seed=3,
            round_=1,
            out_path=out,
            dataset="toy",
            method_name="mine",
        )
    message = str(err.value)
    lab, unl = inputs.labeled_idx[0], inputs.unlabeled_idx[0]
    assert message.startswith("toy/mine seed 3: the query that makes round 1 stopped, as ")
    assert "strategy 'broken' returned [" in message
    assert what.format(lab=lab, unl=unl) in message, message
    assert message.endswith(".") and message.count(". ") == 0 and "\n" not in message
    assert isinstance(err.value, ValueError)  # the job log prints it as one line
    assert not out.exists() and not out.parent.exists()


def test_a_built_in_strategy_breaking_select_is_named_too():
    class Bad(strategies.Strategy):
        name = "bad_positions"

        def _select(self, inputs, k, rng):
            return np.zeros(k, dtype=np.int64)

    with pytest.raises(StrategyContractError, match="strategy 'bad_positions' returned the pos"):
        Bad().select(make_inputs(), 3, np.random.default_rng(0))


@pytest.mark.parametrize(
    ("entry", "words"),
    [
        ("duis = my_strategies:FarthestFromLabeled", "takes the name of the built-in"),
        ("notone = my_strategies:np", "not a spl_al.strategies.Strategy subclass"),
        ("gone = no_such_module:X", "failed to load: ModuleNotFoundError"),
    ],
)
def test_a_broken_entry_point_is_one_sentence(tmp_path, monkeypatch, entry, words):
    name, value = (p.strip() for p in entry.split("="))
    site = make_distribution(
        tmp_path / "site", "bad_dist", {"my_strategies": docs_example()}, {name: value}
    )
    monkeypatch.syspath_prepend(str(site))
    with pytest.raises(ValueError, match=words) as err:
        strategies.load_entry_points(force=True)
    assert f"entry point {name!r}" in str(err.value) and "of bad_dist" in str(err.value)
    monkeypatch.undo()
    strategies.load_entry_points(force=True)


# ------------------------------------------------------------ one round of the CI DAG

ONE_ROUND = {
    # config/ci.yaml's real_cls, its budget experiment alone (round 0, one query,
    # round 1, one seed) with the entry point's strategy in both families
    "methods": {"far": {"strategy": "farthest"}, "bad": {"strategy": "broken"}},
    "sweeps": None,
    "datasets": {
        "street_seg": None,
        "street_pc": None,
        "real_cls": {
            "experiments": {
                "budget": {"methods": ["random", "far", "duis"], "seeds": [1], "rounds": 2},
                "levels": None,
                "ablation": None,
                "sensitivity": None,
            },
            "robustness": {"enabled": False},
        },
    },
}


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake not installed")
def test_an_entry_point_strategy_runs_one_round_of_the_ci_dag(on_path, tmp_path):
    override = tmp_path / "plugin.yaml"
    override.write_text(yaml.safe_dump(ONE_ROUND))
    results = tmp_path / "results"
    env = {**os.environ}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), str(on_path)])
    # one run: the budget table, and the round of a strategy that returns a labeled
    # index, which must stop alone (--keep-going) in one sentence, writing no file
    table_csv = results / "real_cls" / "tables" / "budget.csv"
    bad = results / "real_cls" / "bad" / "seed1" / "round1" / "labeled.json"
    cmd = [*SNAKEMAKE, "-j2", "--keep-going", str(table_csv), str(bad)]
    cmd += ["--configfile", CI_CONFIG, str(override), "--config", f"results={results}"]
    run = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, env=env)
    out = run.stdout + run.stderr
    assert run.returncode != 0 and table_csv.is_file(), out[-3000:]
    assert "real_cls/bad seed 1: the query that makes round 1 stopped, as strategy 'broken'" in out
    assert not bad.exists()
    table = pd.read_csv(table_csv)
    assert set(table["method"]) == {"random", "far", "syn_random", "syn_far", "duis"}
    initial = json.loads((results / "real_cls" / "initial" / "seed1.json").read_text())
    for method in ("far", "syn_far"):
        run_dir = results / "real_cls" / method / "seed1"
        picked = json.loads((run_dir / "round1" / "labeled.json").read_text())["queried"]
        assert len(picked) == len(set(picked)) == 6
        assert not set(picked) & set(initial["pool_indices"])
        # what the strategy was given: index sets and features, no label
        with np.load(run_dir / "round0" / "scores.npz") as scores:
            assert set(scores.files) == {
                "unlabeled_idx", "labeled_idx", "features", "labeled_features"
            }  # fmt: skip
    # the same seed gives the same picks: rerun one query from its scores
    again = query_round(
        results / "real_cls" / "far" / "seed1" / "round0" / "scores.npz",
        results / "real_cls" / "initial" / "seed1.json",
        method={"strategy": "farthest"},
        batch=6,
        seed=1,
        round_=1,
        out_path=tmp_path / "again.json",
    )
    first = json.loads(
        (results / "real_cls" / "far" / "seed1" / "round1" / "labeled.json").read_text()
    )
    assert again["queried"] == first["queried"]


def test_a_package_taken_off_the_path_takes_its_strategies_with_it(plugin_dir, monkeypatch):
    monkeypatch.syspath_prepend(str(plugin_dir))
    assert "farthest" in strategies.names()
    monkeypatch.undo()
    assert "farthest" not in strategies.names() and "broken" not in strategies.names()
    assert set(strategies.base.builtin_names()) <= set(strategies.names())

"""Configuration helpers: removed keys, validation messages, folders from the environment."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from snakemake.utils import update_config

from spl_al.config import check_config, drop_removed, real_captures_dir
from spl_al.experiment.plan import check_plan
from spl_al.models import build_model
from spl_al.training import TrainConfig


def test_null_removes_a_key_at_any_depth():
    config = {"a": None, "b": {"c": None, "d": 1, "e": {"f": None}}, "g": [None]}
    assert drop_removed(config) == {"b": {"d": 1, "e": {}}, "g": [None]}


def test_unknown_key_is_named(tmp_path):
    schema = tmp_path / "schema.yaml"
    schema.write_text(
        "type: object\nadditionalProperties: false\nproperties: {a: {type: integer}}\n"
    )
    with pytest.raises(ValueError, match=r"config key '\(top level\)': Additional properties"):
        check_config({"a": 1, "bogus": 2}, schema)


def test_real_captures_config_wins_over_the_environment(tmp_path):
    given, env_dir = tmp_path / "given", tmp_path / "env"
    given.mkdir()
    env_dir.mkdir()
    env = {"SPL_AL_REAL_CAPTURES": str(env_dir)}
    assert real_captures_dir({"photon": {"real_captures": str(given)}}, env) == given
    assert real_captures_dir({"photon": {}}, env) == env_dir
    assert real_captures_dir({"photon": {}}, {}) is None
    with pytest.raises(
        ValueError, match=r"config key 'photon.real_captures' names .* not a folder"
    ):
        real_captures_dir({"photon": {"real_captures": str(tmp_path / "no")}}, env)


def test_paper_config_trains_with_the_papers_recipe_whatever_the_defaults():
    """config/paper.yaml is merged over config/config.yaml (nulls then removed, as the
    Snakefile does): the default CPU classifier's layers and augmentation must not
    leak into the paper's ResNet-18 training."""
    root = Path(__file__).resolve().parents[1]
    config = yaml.safe_load((root / "config" / "config.yaml").read_text())
    update_config(config, yaml.safe_load((root / "config" / "paper.yaml").read_text()))
    drop_removed(config)
    for name in ("real_cls", "synth_cls"):
        train = config["datasets"][name]["train"]
        assert train["model"] == {"arch": "resnet18"}
        build_model("classification", 11, **train["model"])
        assert TrainConfig.from_dict(train["fit"]) == TrainConfig.paper()


def _merged(*names: str) -> dict:
    """config/config.yaml with the named override files merged on top, as Snakemake does."""
    root = Path(__file__).resolve().parents[1] / "config"
    config = yaml.safe_load((root / "config.yaml").read_text())
    for name in names:
        update_config(config, yaml.safe_load((root / name).read_text()))
    return drop_removed(config)


@pytest.mark.parametrize("name", ["ci.yaml", "paper.yaml", "harder.yaml", "decisive.yaml"])
def test_every_shipped_override_is_a_valid_config(name):
    """The schema and the plan's cross-key checks (per-round batch lists, N_cand at most
    half the unlabeled pool at every query) both pass."""
    root = Path(__file__).resolve().parents[1] / "config"
    config = _merged(name)
    check_config(config, root / "schema.yaml")
    check_plan(config)


def test_decisive_config_extends_the_default_run_seeds_of_real_cls_only():
    """Seeds 1-6 of the 24-seed run must be the default run's own rounds: the same
    data, recipe and methods, only more seeds (and fewer experiments)."""
    default, decisive = _merged(), _merged("decisive.yaml")
    assert list(decisive["datasets"]) == ["real_cls"]
    assert decisive["results"] != default["results"]
    ours, theirs = decisive["datasets"]["real_cls"], default["datasets"]["real_cls"]
    for key in ("synthesis", "variants", "al", "train", "task", "source"):
        assert ours[key] == theirs[key], key
    for experiment in ("budget", "ablation"):
        seeds = ours["experiments"][experiment]["seeds"]
        assert len(seeds) == len(set(seeds)) >= 20
        assert seeds[:6] == theirs["experiments"][experiment]["seeds"]
        mine = {k: v for k, v in ours["experiments"][experiment].items() if k != "seeds"}
        base = {k: v for k, v in theirs["experiments"][experiment].items() if k != "seeds"}
        if experiment == "budget":  # the default's methods, plus two low-budget baselines
            added = [m for m in mine["methods"] if m not in base["methods"]]
            assert added == ["typiclust", "probcover"]
            assert [m for m in mine["methods"] if m not in added] == base["methods"]
            mine["methods"] = base["methods"]
        assert mine == base
    assert decisive["methods"] == default["methods"]


def _round_steps(config: dict, dataset: str, steps_by: str | None = None) -> dict:
    """(method, round) -> optimiser steps of that round's training, as the pipeline
    trains it (groups labeled at the round, the method's variants per group)."""
    from spl_al.bench.projection import method_variants
    from spl_al.experiment.plan import dataset_runs, labeled_at

    entry = config["datasets"][dataset]
    fit = {k: v for k, v in entry["train"]["fit"].items() if v is not None}
    cfg = TrainConfig.from_dict(fit if steps_by is None else {**fit, "steps_by": steps_by})
    steps = {}
    for (method, _seed), rounds in dataset_runs(config, dataset).items():
        m = method_variants(config, dataset, method)
        for r in range(rounds):
            groups = labeled_at(entry["al"], r)
            steps[method, r] = cfg.total_steps(groups * (1 + m), groups)
    return steps


@pytest.mark.parametrize("name", [None, "ci.yaml", "paper.yaml", "harder.yaml", "decisive.yaml"])
def test_every_shipped_config_trains_every_method_the_same_steps(name):
    config = _merged(*([name] if name else []))
    for dataset in config["datasets"]:
        assert config["datasets"][dataset]["train"]["fit"].get("steps_by", "groups") == "groups"
        per_round: dict[int, set] = {}
        for (_method, r), steps in _round_steps(config, dataset).items():
            per_round.setdefault(r, set()).add(steps)
        assert all(len(s) == 1 for s in per_round.values()), (dataset, per_round)


def test_the_default_run_takes_the_steps_it_took_before_the_policy():
    """The default config's floors (min_steps, steps_per_group) already set every
    round's length: its results (docs/results.md) are the same under either policy."""
    config = _merged()
    for dataset in config["datasets"]:
        assert _round_steps(config, dataset, "groups") == _round_steps(config, dataset, "images")


def test_training_notes_name_steps_that_scale_with_images():
    from spl_al.config import training_notes

    config = _merged()
    assert training_notes(config, "street_seg") == []
    config["datasets"]["street_seg"]["train"]["fit"]["steps_by"] = "images"
    (note,) = training_notes(config, "street_seg")
    assert "steps_by: images" in note and "steps" in note
    check_config(config, Path(__file__).resolve().parents[1] / "config" / "schema.yaml")
    config["datasets"]["street_seg"]["train"]["fit"]["steps_by"] = "scans"
    with pytest.raises(ValueError, match=r"'datasets.street_seg.train.fit.steps_by'"):
        check_config(config, Path(__file__).resolve().parents[1] / "config" / "schema.yaml")

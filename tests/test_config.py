"""Configuration helpers: removed keys, validation messages, folders from the environment."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from snakemake.utils import update_config

from spl_al.config import check_config, drop_removed, real_captures_dir
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

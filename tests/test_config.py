"""Configuration helpers: removed keys, validation messages, folders from the environment."""

from __future__ import annotations

import pytest

from spl_al.config import check_config, drop_removed, real_captures_dir


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

"""Budget points of a config: per-round batches (``al.batch`` as a list)."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml

from spl_al.config import check_config
from spl_al.experiment.plan import batch_of, check_plan, labeled_at

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = ROOT / "config" / "schema.yaml"


@pytest.fixture(scope="module")
def default():
    return yaml.safe_load((ROOT / "config" / "config.yaml").read_text())


def test_a_batch_list_needs_one_batch_per_query(default):
    config = copy.deepcopy(default)
    entry = config["datasets"]["synth_cls"]  # 3 rounds: 2 queries
    for batch, given in (([40], 1), ([40, 40, 40], 3)):
        entry["al"]["batch"] = batch
        with pytest.raises(ValueError) as err:
            check_plan(config)
        message = str(err.value)
        assert message.startswith("config key 'datasets.synth_cls.al.batch' lists ")
        assert f"lists {given} per-round batches but the dataset's experiments make 2" in message
        assert message.count(". ") == 0 and message.endswith(".")
    entry["al"]["batch"] = [40, 20]
    check_plan(config)


@pytest.mark.parametrize("batch", [[6, 0, 9, 9], []])
def test_the_schema_takes_an_integer_or_a_list_of_positive_integers(default, batch):
    config = copy.deepcopy(default)
    check_config(config, SCHEMA)
    config["datasets"]["street_pc"]["al"]["batch"] = batch
    with pytest.raises(ValueError, match=r"'datasets\.street_pc\.al\.batch'.*not valid"):
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

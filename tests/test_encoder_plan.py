"""The encoder plan (``datasets.NAME.embedding.encoder``: seeds, block): which encoder
each run seed reads, and one sentence for each way the plan can be wrong."""

import pytest

from spl_al.experiment.encoders import check_encoders, encoder_of, encoder_recipe, encoder_seeds


def _entry(**encoder):
    return {"embedding": {"encoder": {"steps": 300, **encoder}, "experiments": {}}}


def test_run_seed_s_reads_encoder_number_s_minus_1_over_block():
    entry = _entry(seeds=[10, 11, 12], block=4)
    assert [encoder_of(entry, s) for s in range(1, 13)] == [10] * 4 + [11] * 4 + [12] * 4
    assert encoder_recipe(entry) == {"steps": 300}
    # more encoders never move a run already made: seed 5 stays on encoder 11
    more = _entry(seeds=[10, 11, 12, 13], block=4)
    assert encoder_of(more, 5) == 11
    # one encoder (the recipe's seed, or none: 0) serves every run seed
    assert encoder_seeds(_entry(seed=4)) == [4] and encoder_of(_entry(seed=4), 99) == 4
    assert encoder_seeds(_entry()) == [0]


@pytest.mark.parametrize(
    ("encoder", "runs", "match"),
    [
        ({"seeds": [1, 2, 1], "block": 2}, range(1, 7), r"lists encoder seed 1 more than once"),
        ({"seeds": [1, 2], "seed": 3, "block": 2}, range(1, 5), "sets both 'seed' and 'seeds'"),
        ({"seeds": [1, 2]}, range(1, 5), r"encoder.block' is missing"),
        ({"seeds": [1, 2, 3], "block": 1}, range(1, 3), r"lists 3 encoders, more than the 2 run"),
        ({"seeds": [1, 2], "block": 2}, range(1, 6), r"run seed 5 reads encoder number 2"),
    ],
)
def test_a_wrong_encoder_plan_is_one_sentence_naming_the_key(encoder, runs, match):
    with pytest.raises(ValueError, match=match) as err:
        check_encoders("real_cls", _entry(**encoder), list(runs), list(runs))
    assert "datasets.real_cls.embedding.encoder" in str(err.value)
    assert str(err.value).count(". ") == 0


def test_the_config_check_refuses_a_plan_before_any_job():
    import yaml

    from spl_al.experiment.plan import check_plan

    with open("config/config.yaml") as f:
        config = yaml.safe_load(f)
    entry = config["datasets"]["real_cls"]["embedding"]
    entry["encoder"] = {**entry["encoder"], "seeds": [0, 0]}
    entry["encoder"].pop("seed", None)
    with pytest.raises(
        ValueError, match=r"real_cls\.embedding\.encoder\.seeds' lists encoder seed 0"
    ):
        check_plan(config)

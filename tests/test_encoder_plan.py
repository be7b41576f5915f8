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


def _default_config():
    import yaml

    with open("config/config.yaml") as f:
        return yaml.safe_load(f)


def test_supervised_seeds_sharing_an_encoder_are_refused_naming_block():
    """The supervised framework counts seeds as independent draws: a method that selects
    on the embedding at seeds 1-3 with block 10 would read one encoder three times."""
    from spl_al.experiment.plan import check_plan

    config = _default_config()
    config["datasets"]["real_cls"]["experiments"]["budget"]["methods"].append("typiclust_ssl")
    with pytest.raises(ValueError) as err:
        check_plan(config)
    message = str(err.value)
    assert message.startswith("config key 'datasets.real_cls.embedding.encoder.block'")
    # (matched: true adds its twin, syn_typiclust_ssl, which reads it too)
    assert "seeds 1 and 2 of 'syn_typiclust_ssl' read the same encoder (seed 0)" in message
    assert message.count(". ") == 0
    # one encoder per run seed: the seeds are independent again
    config["datasets"]["real_cls"]["embedding"]["encoder"]["block"] = 1
    config["datasets"]["real_cls"]["embedding"]["experiments"] = None
    check_plan(config)


def test_a_supervised_run_that_reads_an_encoder_names_it_in_its_records():
    from spl_al.experiment.plan import encoder_read
    from spl_al.experiment.round_steps import RoundId, _metrics_record

    config = _default_config()
    config["datasets"]["real_cls"]["embedding"]["encoder"].update(block=1)
    assert encoder_read(config, "real_cls", "typiclust_ssl", seed=3) == 2  # seed s: encoder s - 1
    assert encoder_read(config, "real_cls", "random", seed=3) is None
    facts = {"task": "classification", "n_train": 770, "n_samples": 1100}
    facts["synthetic_standin"] = True
    which = RoundId("real_cls", "typiclust_ssl", 3, 1)
    metrics = {"accuracy": 0.5, "per_level": {}}
    record = _metrics_record(facts, {"encoder": 2}, which, 40, metrics, {})
    assert record["encoder"] == 2
    assert "encoder" not in _metrics_record(facts, {}, which, 40, metrics, {})

"""Configuration helpers: removed keys, validation messages, folders from the environment."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from snakemake.utils import update_config

from spl_al.config import check_config, drop_removed, real_captures_dir, select_datasets
from spl_al.experiment.plan import check_plan
from spl_al.experiment.shared_embedding import share_embeddings
from spl_al.models import build_model
from spl_al.training import TrainConfig

ROOT = Path(__file__).resolve().parents[1]


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


@pytest.mark.parametrize(
    ("batch", "key", "message"),
    [
        (0, "batch", "0 is less than the minimum of 1"),
        ([6, 0], "batch.1", "0 is less than the minimum of 1"),
        ("x", "batch", "'x' is not integer >= 1, or list of integer >= 1"),
    ],
)
def test_a_value_that_fits_no_alternative_names_the_key_and_its_bound(
    batch, key, message, monkeypatch
):
    """al.batch is an integer or a list (oneOf): the message is the alternative of the
    value's own type, as docs/configuration.md quotes it, not "not valid under any of
    the given schemas"."""
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config["datasets"]["real_cls"]["al"]["batch"] = batch
    monkeypatch.chdir(ROOT)  # the path the Snakefile gives
    with pytest.raises(ValueError) as err:
        check_config(config, "config/schema.yaml")
    assert str(err.value) == (
        f"config key 'datasets.real_cls.al.{key}': {message} (checked against config/schema.yaml)."
    )
    if batch == 0:  # the page's example, word for word
        page = " ".join((ROOT / "docs" / "configuration.md").read_text().split())
        assert f"`Error: {err.value}`" in page


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


def _merged(*names: str, share: bool = True) -> dict:
    """config/config.yaml with the named override files merged on top, as Snakemake does
    (and the Snakefile resolves shared embeddings)."""
    root = Path(__file__).resolve().parents[1] / "config"
    config = yaml.safe_load((root / "config.yaml").read_text())
    user: dict = {}
    for name in names:
        update_config(user, yaml.safe_load((root / name).read_text()))
    update_config(config, user)
    drop_removed(config)
    select_datasets(config, user)
    if share:
        share_embeddings(config)
    return config


SHIPPED = [
    "ci.yaml",
    "paper.yaml",
    "harder.yaml",
    "decisive.yaml",
    "decisive-synth_cls.yaml",
    "decisive-street_seg.yaml",
    "decisive-street_pc.yaml",
    "street.yaml",
]


def test_paper_config_trains_every_round_from_fresh_weights():
    """The paper's protocol is a fresh model per round: no dataset of config/paper.yaml
    keeps the default config's warm start (street_pc's, synth_cls's, street_seg's)."""
    config = _merged("paper.yaml")
    warm = {name: entry["train"].get("warm_start") for name, entry in config["datasets"].items()}
    assert warm == dict.fromkeys(["real_cls", "synth_cls", "street_seg", "street_pc"])


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_override_is_a_valid_config(name):
    """The schema and the plan's cross-key checks (per-round batch lists, N_cand at most
    half the unlabeled pool at every query) both pass."""
    root = Path(__file__).resolve().parents[1] / "config"
    config = _merged(name)
    check_config(config, root / "schema.yaml")
    check_plan(config)


def test_decisive_config_extends_the_default_run_of_real_cls():
    """The decisive run of real_cls is the default run's data, recipe and first seeds,
    at 24 seeds over the paper's fourth round (80 labeled), with the matched twin of
    every baseline of the paper and of the two low-budget baselines, and Random on
    observed images (the base of the decomposition)."""
    from spl_al.experiment.plan import experiments_of

    default, decisive = _merged(), _merged("decisive.yaml")
    assert list(decisive["datasets"]) == ["real_cls"]
    assert decisive["results"] != default["results"]
    ours, theirs = decisive["datasets"]["real_cls"], default["datasets"]["real_cls"]
    for key in ("synthesis", "variants", "al", "train", "task", "source"):
        assert ours[key] == theirs[key], key
    budget, base = ours["experiments"]["budget"], theirs["experiments"]["budget"]
    assert len(budget["seeds"]) == len(set(budget["seeds"])) == 24
    assert budget["seeds"][:3] == base["seeds"]
    matched = {f"syn_{m}" for m in ("random", "entropy", "margin", "coreset", "badge")}
    low_budget = {"syn_typiclust", "syn_probcover", "syn_dropquery"}
    planned = set(experiments_of(decisive, "real_cls")["budget"]["methods"])
    assert planned == matched | low_budget | {"random", "syn_diversity", "duis"}
    assert budget["matched"] and budget["rounds"] == 4 > base["rounds"]  # 20-80 labeled
    assert set(ours["experiments"]["ablation"]["seeds"]) <= set(budget["seeds"])
    assert decisive["methods"] == default["methods"]


@pytest.mark.parametrize(
    "name, dataset",
    [
        ("decisive.yaml", "real_cls"),
        ("decisive-synth_cls.yaml", "synth_cls"),
        ("decisive-street_seg.yaml", "street_seg"),
        ("decisive-street_pc.yaml", "street_pc"),
    ],
)
def test_each_decisive_config_runs_one_dataset_with_both_families(name, dataset):
    """One decisive config per dataset, all into one results folder: the default's data,
    recipe and seeds 1.. extended, with the matched family and the decomposition."""
    from spl_al.experiment.plan import experiments_of
    from spl_al.report.decomposition import METHODS

    root = Path(__file__).resolve().parents[1] / "config"  # every dataset it defines
    default = drop_removed(yaml.safe_load((root / "config.yaml").read_text()))
    decisive = _merged(name)
    assert list(decisive["datasets"]) == [dataset]
    assert decisive["results"] == "results-decisive"
    ours, theirs = decisive["datasets"][dataset], default["datasets"][dataset]
    for key in ("synthesis", "variants", "al", "train", "task", "source"):
        assert ours[key] == theirs[key], key
    budget = experiments_of(decisive, dataset)["budget"]
    assert set(METHODS) <= set(budget["methods"])
    assert len(budget["families"]["matched"]) >= 6  # five twins, Syn+Diversity, DUIS
    seeds = budget["seeds"]
    # seeds 1.. extended (synth_cls has no supervised experiment in the default run)
    assert seeds[:3] == [1, 2, 3] and len(seeds) >= 8


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


@pytest.mark.parametrize("name", [None, *SHIPPED])
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


def test_training_notes_name_a_warm_start():
    from spl_al.config import training_notes

    config = _merged("decisive-street_seg.yaml")
    config["datasets"]["street_seg"]["train"]["warm_start"] = None
    assert training_notes(config, "street_seg") == []
    config["datasets"]["street_seg"]["train"]["warm_start"] = {"min_steps": 150}
    (note,) = training_notes(config, "street_seg")
    assert "previous-round model" in note and "min_steps: 150" in note
    schema = Path(__file__).resolve().parents[1] / "config" / "schema.yaml"
    check_config(config, schema)
    config["datasets"]["street_seg"]["train"]["warm_start"] = {"mixup": 0.5}
    with pytest.raises(ValueError, match="warm_start"):
        check_config(config, schema)
    # the default run's synth_cls fine-tunes in its decisive config, but trains no network
    # in the default run (its embedding framework alone): no note there
    assert _merged()["datasets"]["synth_cls"]["train"]["warm_start"]
    assert training_notes(_merged(), "synth_cls") == []


def test_training_notes_name_steps_that_scale_with_images():
    from spl_al.config import training_notes

    config = _merged()  # real_cls trains every round fresh: no warm-start note
    assert training_notes(config, "real_cls") == []
    config["datasets"]["real_cls"]["train"]["fit"]["steps_by"] = "images"
    (note,) = training_notes(config, "real_cls")
    assert "steps_by: images" in note and "steps" in note
    check_config(config, Path(__file__).resolve().parents[1] / "config" / "schema.yaml")
    config["datasets"]["real_cls"]["train"]["fit"]["steps_by"] = "scans"
    with pytest.raises(ValueError, match=r"'datasets.real_cls.train.fit.steps_by'"):
        check_config(config, Path(__file__).resolve().parents[1] / "config" / "schema.yaml")


# ---------------------------------------------------------------- only_datasets


def merged(*overrides: dict) -> tuple[dict, dict]:
    """(config/config.yaml with ``overrides`` merged as Snakemake does, the overrides
    alone), null keys removed from the first."""
    import copy

    user: dict = {}
    for over in overrides:
        update_config(user, copy.deepcopy(over))
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    update_config(config, copy.deepcopy(user))
    return drop_removed(config), user


FRAMES = {
    "task": "classification",
    "source": "synthetic",
    "variants": {"n": 2, "shards": 1, "seed": 0},
    "al": {"initial": 10, "batch": 10},
    "train": {"model": {"arch": "smallcnn"}, "fit": {"epochs": 1}},
    "experiments": {"budget": {"methods": ["duis"], "seeds": [1], "rounds": 2}},
}


def test_only_datasets_keeps_exactly_the_named_ones_and_inherits_nothing_new():
    config, user = merged({"only_datasets": ["frames"], "datasets": {"frames": FRAMES}})
    assert select_datasets(config, user) == {}
    assert list(config["datasets"]) == ["frames"]
    assert config["datasets"]["frames"] == FRAMES
    check_config(config, ROOT / "config" / "schema.yaml")


def test_without_only_datasets_the_default_runs_datasets_run():
    config, user = merged({"datasets": {"real_cls": {"al": {"batch": 7}}}})
    defaults = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    assert select_datasets(config, user) == {}
    assert list(config["datasets"]) == defaults["only_datasets"] == ["real_cls", "synth_cls"]
    assert {"street_seg", "street_pc"} < set(defaults["datasets"])  # defined, not run
    assert config["datasets"]["real_cls"]["al"]["batch"] == 7


def test_a_default_dataset_set_to_null_leaves_the_default_list():
    config, user = merged({"datasets": {"synth_cls": None}})
    select_datasets(config, user)
    assert list(config["datasets"]) == config["only_datasets"] == ["real_cls"]


def test_an_added_dataset_must_be_named_in_only_datasets():
    """A config that adds a dataset and forgets only_datasets would otherwise run the
    defaults and silently not its own."""
    mine = {"task": "classification", "source": "folder", "path": "/data/mine"}
    config, user = merged({"datasets": {"mine": mine}})
    with pytest.raises(ValueError, match=r"'datasets.mine' .* only_datasets"):
        select_datasets(config, user)
    config, user = merged({"only_datasets": ["mine"], "datasets": {"mine": mine}})
    select_datasets(config, user)
    assert list(config["datasets"]) == ["mine"]


def test_a_reused_default_name_lists_every_key_it_inherited():
    over = {"only_datasets": ["real_cls"], "datasets": {"real_cls": {"path": "/data/x"}}}
    config, user = merged(over)
    inherited = select_datasets(config, user)
    assert list(config["datasets"]) == ["real_cls"]
    assert inherited["real_cls"]["synthesis.image_shape"] == [64, 64]
    assert "path" not in inherited["real_cls"]
    # every key of the entry is either the user's or listed
    given = {"path"}
    from spl_al.config import _leaves

    assert set(_leaves(config["datasets"]["real_cls"])) == given | set(inherited["real_cls"])


@pytest.mark.parametrize(
    "over, message",
    [
        ({"only_datasets": []}, r"config key 'only_datasets' is empty"),
        ({"only_datasets": ["frmes"]}, r"config key 'only_datasets' names 'frmes'.*expected one"),
        ({"only_datasets": "real_cls"}, r"config key 'only_datasets' is 'real_cls'; expected a"),
        (
            {"only_datasets": ["mine"], "datasets": {"mine": {"task": "classification"}}},
            r"config key 'datasets.mine.source' is missing; expected a dataset source",
        ),
        (
            {d: None for d in ["real_cls", "synth_cls", "street_seg", "street_pc"]},
            r"config key 'datasets' holds no dataset",
        ),
    ],
)
def test_a_bad_selection_is_one_sentence_naming_the_key(over, message):
    if "only_datasets" not in over and "datasets" not in over:
        over = {"datasets": over}
    config, user = merged(over)
    with pytest.raises(ValueError, match=message) as err:
        select_datasets(config, user)
    assert "\n" not in str(err.value) and str(err.value).endswith(".")


def test_the_plan_names_source_shape_methods_seeds_rounds_and_budgets():
    from spl_al.experiment.overview import jobs_line, plan_text

    config, user = merged({"only_datasets": ["frames"], "datasets": {"frames": FRAMES}})
    select_datasets(config, user)
    text = plan_text(config)
    assert "results in results/" in text
    assert "frames: classification, source synthetic, 64x64 images" in text
    assert "budget: methods duis; seeds 1; 2 rounds at 10, 20 labeled groups" in text
    assert jobs_line(12, "results") == "Plan: 12 jobs to run; results in results/"
    config, user = merged({"only_datasets": ["real_cls"]})
    inherited = select_datasets(config, user)
    assert "synthesis.image_shape=[64, 64]" in plan_text(config, inherited)


def test_the_default_run_s_embedding_framework_has_12_encoders_of_10_seeds():
    from spl_al.experiment.encoders import encoder_of, encoder_seeds
    from spl_al.experiment.overview import plan_text
    from spl_al.experiment.plan import budget_families, dataset_runs

    config = _merged()
    for dataset in ("real_cls", "synth_cls"):
        runs = dataset_runs(config, dataset, "embedding")
        assert {seed for _m, seed in runs} == set(range(1, 121))
        entry = config["datasets"][dataset]
        # 2/2^K <= 0.05/30: the sign-flip test over K encoders can pass Holm over the
        # largest claim's 30 comparisons (3 query rounds x 10 matched baselines)
        k = len(encoder_seeds(entry))
        assert k >= 12 and 2 / 2**k <= 0.05 / 30
        per = {
            e: sum(encoder_of(entry, s) == e for s in range(1, 121)) for e in encoder_seeds(entry)
        }
        assert set(per.values()) == {10}
        families = budget_families(config, dataset, framework="embedding")
        for low in ("typiclust", "probcover", "maxherding"):
            assert low in families["paper"] and f"syn_{low}" in families["matched"]
    # the supervised framework keeps its 3 seeds on real_cls; synth_cls's runs in
    # config/decisive-synth_cls.yaml (the default run affords its encoders instead)
    assert {seed for _m, seed in dataset_runs(config, "real_cls")} == {1, 2, 3}
    assert not dataset_runs(config, "synth_cls")
    text = plan_text(config)
    assert "12 self-supervised encoders" in text and "seeds 1-120 (120)" in text


def test_the_street_config_s_embedding_framework_has_12_encoders_and_100_seeds():
    """street_seg and street_pc in config/street.yaml's embedding framework: at least
    12 encoders each (street_pc's street_seg's: the same scans), at least 100 run
    seeds, the paper's five baselines, the low-budget ones and DropQuery, every table
    kind."""
    from spl_al.experiment.encoders import encoder_seeds
    from spl_al.experiment.plan import budget_families, dataset_runs

    config = _merged("street.yaml")
    seeds = {}
    for dataset in ("street_seg", "street_pc"):
        entry = config["datasets"][dataset]
        seeds[dataset] = encoder_seeds(entry)
        assert len(seeds[dataset]) >= 12
        runs = dataset_runs(config, dataset, "embedding")
        assert len({seed for _m, seed in runs}) >= 100
        families = budget_families(config, dataset, framework="embedding")
        for method in ("random", "entropy", "margin", "coreset", "badge", "typiclust"):
            assert method in families["paper"] and f"syn_{method}" in families["matched"]
        assert "dropquery" in families["paper"]
        experiments = entry["embedding"]["experiments"]
        assert {"budget", "levels", "ablation", "sensitivity"} <= set(experiments)
    assert seeds["street_seg"] == seeds["street_pc"]  # one experiment, shared
    assert config["datasets"]["street_pc"]["embedding"]["shared"] == "street_seg"


def test_dropquery_on_segmentation_runs_in_the_embedding_framework_alone():
    """DropQuery reads a classifier's last layer: a segmenting network has none, the
    dense probe gives it one."""
    config = _merged("street.yaml")
    check_plan(config)  # the street embedding framework runs dropquery
    budget = {"methods": ["random", "dropquery"], "seeds": [1], "rounds": 2}
    config["datasets"]["street_seg"]["experiments"]["budget"] = budget
    with pytest.raises(ValueError, match=r"'methods\.dropquery'.*street_seg is a segmentation"):
        check_plan(config)


@pytest.mark.parametrize(
    ("change", "key", "message"),
    [
        ({"encoder": {"stpes": 3}}, "datasets.real_cls.embedding.encoder", "stpes"),
        (
            {"probe": {"c": 0}},
            "datasets.real_cls.embedding.probe.c",
            "less than or equal to the minimum of 0",
        ),
        (
            {"experiments": {"budget": {"framework": "x"}}},
            "datasets.real_cls.embedding.experiments.budget.framework",
            "'x' is not one of",
        ),
    ],
)
def test_a_bad_embedding_block_names_its_key(change, key, message):
    config = _merged()
    update_config(config["datasets"]["real_cls"]["embedding"], change)
    schema = Path(__file__).resolve().parents[1] / "config" / "schema.yaml"
    with pytest.raises(ValueError, match=message) as err:
        check_config(config, schema)
    assert key in str(err.value)


def test_a_framework_key_must_name_the_framework_of_where_it_sits():
    config = _merged()
    entry = config["datasets"]["real_cls"]
    entry["embedding"]["experiments"]["budget"]["framework"] = "embedding"
    entry["experiments"]["levels"]["framework"] = "supervised"
    schema = Path(__file__).resolve().parents[1] / "config" / "schema.yaml"
    check_config(config, schema)
    check_plan(config)  # the keys that agree with their location are accepted
    entry["experiments"]["budget"]["framework"] = "embedding"
    check_config(config, schema)
    with pytest.raises(
        ValueError,
        match=r"'datasets\.real_cls\.experiments\.budget\.framework': 'embedding' but "
        r"experiments under 'experiments' run the supervised framework; move the experiment "
        r"under 'embedding\.experiments'",
    ):
        check_plan(config)


def test_features_embedding_is_refused_for_a_strategy_that_reads_the_model():
    config = _merged()
    config["methods"]["margin_ssl"] = {"strategy": "margin", "features": "embedding"}
    config["datasets"]["real_cls"]["experiments"]["budget"]["methods"].append("margin_ssl")
    with pytest.raises(ValueError, match=r"'methods\.margin_ssl\.features'.*margin also needs"):
        check_plan(config)


def test_a_folder_without_path_or_standin_is_refused_before_any_job():
    from spl_al.config import is_standin

    config = _merged()
    assert is_standin(config["datasets"]["real_cls"])
    config["datasets"]["real_cls"]["standin"] = False
    assert not is_standin(config["datasets"]["real_cls"])
    with pytest.raises(ValueError, match=r"'datasets\.real_cls\.path': dataset source is 'f"):
        check_plan(config)


def test_the_second_draw_config_changes_the_encoder_seeds_alone():
    """config/encoders-draw2.yaml: 12 encoders disjoint from the default's, the same
    everything else (so `python -m spl_al.bench draws` compares like with like)."""
    from spl_al.experiment.encoders import encoder_seeds
    from spl_al.experiment.plan import check_plan

    default, draw2 = _merged(), _merged("encoders-draw2.yaml")
    check_plan(draw2)
    for name in ("real_cls", "synth_cls"):
        first = encoder_seeds(default["datasets"][name])
        second = encoder_seeds(draw2["datasets"][name])
        assert len(second) == len(first) == 12 and not set(first) & set(second)
        for config in (default, draw2):
            config["datasets"][name]["embedding"]["encoder"].pop("seeds")
    assert draw2.pop("results") == "results/draw2"
    default.pop("results")
    assert draw2 == default


def test_a_sweep_point_keeps_the_dataset_s_parameters_but_the_one_it_varies():
    """One parameter varied, the others the dataset's: street_seg's N_cand of 80 in
    duis_alpha0.25, the swept value in duis_ncand40."""
    from spl_al.experiment.plan import dataset_method

    config = _merged("street.yaml")
    assert dataset_method(config, "street_seg", "duis_alpha0.25").params["n_cand"] == 80
    assert dataset_method(config, "street_seg", "duis_alpha0.25").params["alpha"] == 0.25
    assert dataset_method(config, "street_seg", "duis_ncand40").params["n_cand"] == 40
    assert dataset_method(_merged(), "real_cls", "duis_alpha0.25").params["n_cand"] == 160


def test_a_shared_embedding_is_its_sources_block_and_refused_when_the_runs_differ():
    """street_pc's embedding: {shared: street_seg} resolves to street_seg's block (the
    same encoders and runs); shared beside other keys, a source outside the run, or a
    dataset whose runs would read another budget is refused in one sentence."""
    config = _merged("street.yaml", share=False)
    assert share_embeddings(config) == {"street_pc": "street_seg"}
    seg, pc = config["datasets"]["street_seg"], config["datasets"]["street_pc"]
    assert pc["embedding"] == {**seg["embedding"], "shared": "street_seg"}
    check_plan(config)
    assert share_embeddings(config) == {"street_pc": "street_seg"}  # resolved: unchanged

    def refused(change, match):
        config = _merged("street.yaml", share=False)
        change(config["datasets"])
        with pytest.raises(ValueError, match=match):
            share_embeddings(config)

    def beside(d):
        d["street_pc"]["embedding"]["encoder"] = {"steps": 10}

    refused(beside, r"'datasets.street_pc.embedding' sets shared and encoder; expected shared")
    refused(lambda d: d.pop("street_seg"), r"names 'street_seg'; expected another dataset")
    refused(lambda d: d["street_pc"]["al"].update(initial=5), r"'datasets.street_pc.al' differs")

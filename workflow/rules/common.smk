# Shared names and input functions; rules live in the other .smk files.
from pathlib import Path

from spl_al.experiment.plan import (
    check_plan,
    dataset_method,
    dataset_runs,
    method_specs,
    sweep_table_spec,
)

RESULTS = config["results"]
DATASETS = list(config["datasets"])
METHODS = method_specs(config)
RUN = f"{RESULTS}/{{dataset}}/{{method}}/seed{{seed}}"


wildcard_constraints:
    dataset="|".join(DATASETS) or "no-dataset",
    method="|".join(sorted(METHODS, key=len, reverse=True)) or "no-method",
    seed=r"\d+",
    round=r"\d+",
    shard=r"\d+",


try:
    check_plan(config)
except ValueError as err:
    sys.exit(f"Error: {err}")


def real_capture_names():
    """Names of the real .mat captures in config photon.real_captures (none if absent)."""
    folder = Path(config["photon"].get("real_captures", ""))
    if not folder.is_dir():
        return []
    return sorted(p.stem for p in folder.glob("*.mat"))


def photon_pictures():
    return [f"{RESULTS}/photon/conditions.png"] + expand(
        f"{RESULTS}/photon/real/{{capture}}.png", capture=real_capture_names()
    )


def n_shards(dataset):
    return int(config["datasets"][dataset]["variants"]["shards"])


def dataset_params(dataset):
    """The dataset's config entry without its experiments and robustness grid: what its
    data depend on."""
    entry = dict(config["datasets"][dataset])
    entry.pop("experiments", None)
    entry.pop("robustness", None)
    return entry


def runs(dataset):
    """(method, seed) -> rounds for one dataset."""
    return dataset_runs(config, dataset)


def metrics_files(dataset):
    return [
        f"{RESULTS}/{dataset}/{method}/seed{seed}/round{r}/metrics.json"
        for (method, seed), rounds in sorted(runs(dataset).items())
        for r in range(rounds)
    ]


def labeled_input(wildcards):
    """Round 0 starts from the seed's shared initial set; round r from round r-1's query."""
    r = int(wildcards.round)
    if r == 0:
        return f"{RESULTS}/{wildcards.dataset}/initial/seed{wildcards.seed}.json"
    return f"{RESULTS}/{wildcards.dataset}/{wildcards.method}/seed{wildcards.seed}/round{r}/labeled.json"


def previous_labeled(wildcards):
    """The labeled set round r - 1 trained on (query of round r adds to it)."""
    r = int(wildcards.round) - 1
    if r == 0:
        return f"{RESULTS}/{wildcards.dataset}/initial/seed{wildcards.seed}.json"
    return f"{RESULTS}/{wildcards.dataset}/{wildcards.method}/seed{wildcards.seed}/round{r}/labeled.json"


def previous_round(wildcards, name):
    r = int(wildcards.round) - 1
    return f"{RESULTS}/{wildcards.dataset}/{wildcards.method}/seed{wildcards.seed}/round{r}/{name}"


def train_params(wildcards):
    """What a round's train job depends on. Strategy parameters (alpha, N_cand) are left
    out: they change only the queries, whose params carry them, so a change reruns a
    method's queries and the rounds after them, not its round 0."""
    entry = config["datasets"][wildcards.dataset]
    method = dataset_method(
        config, wildcards.dataset, wildcards.method, METHODS
    ).as_dict()
    method.pop("params")
    return {
        "train": entry["train"],
        "method": method,
        "ratio_of": entry["al"].get("ratio_of", "train"),
    }


def query_group(wildcards):
    """Query of round r + 1 runs in one submission with round r's train and score."""
    r = int(wildcards.round) - 1
    return f"round_{wildcards.dataset}_{wildcards.method}_{wildcards.seed}_{r}"


def dataset_outputs(dataset):
    tables = f"{RESULTS}/{dataset}/tables"
    figures = f"{RESULTS}/{dataset}/figures"
    out = [
        f"{tables}/summary.json",
        f"{figures}/contact_sheet.png",
        f"{figures}/variants_sheet.png",
    ]
    for table in dataset_tables(dataset):
        out += [f"{tables}/{table}.{ext}" for ext in ("csv", "md", "tex")]
    if "budget" in config["datasets"][dataset].get("experiments", {}):
        out += [f"{figures}/curves.{ext}" for ext in ("png", "pdf")]
        out += [f"{figures}/level_curves.{ext}" for ext in ("png", "pdf")]
        out += [f"{figures}/aubc.{ext}" for ext in ("png", "pdf")]
    if dataset_tables(dataset):
        out += [
            f"{tables}/{name}.{ext}"
            for name in ("comparisons", "claims")
            for ext in ("csv", "md")
        ]
    out += robustness_outputs(dataset)
    return out


def dataset_tables(dataset):
    """The tables a dataset's experiments ask for (budget, levels, ablation, sensitivity)."""
    exps = config["datasets"][dataset].get("experiments", {})
    return [t for t in ("budget", "levels", "ablation", "sensitivity") if t in exps]


# Condition robustness map (workflow/rules/robustness.smk).


def robustness_grid(dataset):
    """The dataset's grid settings: the top-level `robustness` entry updated by the
    dataset's own; None when off (no grid, no budget experiment, or enabled: false)."""
    entry = config["datasets"][dataset]
    merged = {
        "shards": 1,
        "seed": 0,
        "test_samples": None,
        **(config.get("robustness") or {}),
        **(entry.get("robustness") or {}),
    }
    if not merged.pop("enabled", True) or "budget" not in entry.get("experiments", {}):
        return None
    return merged if merged.get("msppp") and merged.get("sbr") else None


def robustness_shards(wildcards):
    grid = robustness_grid(wildcards.dataset)
    return expand(
        f"{RESULTS}/{wildcards.dataset}/robustness/grid/shard{{i}}.npz",
        i=range(int(grid["shards"])),
    )


def robustness_evals(wildcards):
    budget = config["datasets"][wildcards.dataset]["experiments"]["budget"]
    return expand(
        f"{RESULTS}/{wildcards.dataset}/robustness/{{method}}/seed{{seed}}.json",
        method=budget["methods"],
        seed=budget["seeds"],
    )


def final_model(wildcards):
    """The budget experiment's last round's model of this method and seed."""
    last = (
        int(config["datasets"][wildcards.dataset]["experiments"]["budget"]["rounds"])
        - 1
    )
    return f"{RESULTS}/{wildcards.dataset}/{wildcards.method}/seed{wildcards.seed}/round{last}/model.pt"


def robustness_outputs(dataset):
    if robustness_grid(dataset) is None:
        return []
    return [
        f"{RESULTS}/{dataset}/tables/robustness.csv",
        f"{RESULTS}/{dataset}/tables/robustness_diff.csv",
        f"{RESULTS}/{dataset}/figures/robustness.png",
        f"{RESULTS}/{dataset}/figures/robustness_diff.png",
    ]

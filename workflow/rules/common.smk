# Shared names and input functions; rules live in the other .smk files.
import shlex
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
    """The dataset's config entry without its experiments: what its data depend on."""
    entry = dict(config["datasets"][dataset])
    entry.pop("experiments", None)
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
    return out


def dataset_tables(dataset):
    """The tables a dataset's experiments ask for (budget, levels, ablation, sensitivity)."""
    exps = config["datasets"][dataset].get("experiments", {})
    return [t for t in ("budget", "levels", "ablation", "sensitivity") if t in exps]


def sspi_args(flag=""):
    """Command-line options naming SSPI's weights when config photon.sspi_weights is set."""
    folder = config["photon"].get("sspi_weights")
    return f"{flag} --weights {shlex.quote(str(folder))}".strip() if folder else ""

# Shared names and input functions; rules live in the other .smk files.
import functools
import os
import shlex
import sys
from pathlib import Path

from snakemake.logging import logger
from snakemake.settings.types import DeploymentMethod, ExecMode

from spl_al.config import (
    dataset_precision,
    real_captures_dir,
    train_setup,
    training_notes,
)
from spl_al.data.raw_captures import (
    CaptureOptions,
    capture_files,
    check_timing,
    not_read,
    picture_files,
    shard_count,
    shard_of,
)
from spl_al.data.external import folder_has_levels
from spl_al.photon.io import ReadOptions
from spl_al.data.label_files import lists_training_rows
from spl_al.deploy.export import NOT_EXPORTED
from spl_al.warm import client as warm_client
from spl_al.warm.server import Server
from spl_al.experiment.overview import jobs_line, plan_text
from spl_al.experiment.provenance import (
    OLDER_RESULTS,
    changes_text,
    older_results,
    rerun_line,
)
from spl_al.experiment.plan import (
    batch_of,
    budget_families,
    check_plan,
    dataset_method,
    dataset_runs,
    experiments_of,
    method_specs,
    sweep_table_spec,
)

RESULTS = config["results"]
DATASETS = list(config["datasets"])
METHODS = method_specs(config)
RUN = f"{RESULTS}/{{dataset}}/{{method}}/seed{{seed}}"
# Datasets whose labels come from a person (oracle: human) and from the data.
HUMAN = [d for d in DATASETS if config["datasets"][d].get("oracle") == "human"]
SIMULATED = [d for d in DATASETS if d not in HUMAN]
# Datasets made from raw photon captures (workflow/rules/captures.smk).
CAPTURES = [d for d in DATASETS if config["datasets"][d]["source"] == "captures"]


def res(rule, key, default):
    """Resource ``key`` (mem_mb in MB, runtime in minutes) of ``rule``'s jobs: the
    job's dataset's ``resources: {rule: {key: value}}``, else the top-level one
    (config/paper.yaml sizes its heavy jobs so), else ``default``, what the default
    config needs (docs/cluster.md). A function of the job's wildcards."""

    def value(wildcards):
        dataset = getattr(wildcards, "dataset", None)
        own = config["datasets"].get(dataset, {}) if dataset else {}
        for entry in (own.get("resources"), config.get("resources")):
            found = (entry or {}).get(rule, {}).get(key)
            if found is not None:
                return found
        return default

    return value


def one_of(names):
    """A wildcard constraint matching exactly ``names`` (nothing when it is empty)."""
    return "|".join(names) or "(?!)"


wildcard_constraints:
    dataset="|".join(DATASETS) or "no-dataset",
    method="|".join(sorted(METHODS, key=len, reverse=True)) or "no-method",
    seed=r"\d+",
    round=r"\d+",
    shard=r"\d+",


try:
    check_plan(config)
    # photon.real_captures, else $SPL_AL_REAL_CAPTURES, else None (no pictures)
    REAL_CAPTURES = real_captures_dir(config)
    # how the pictures read their captures: a dataset's `captures:` reader options
    PICTURE_OPTIONS = ReadOptions.from_dict(
        config["photon"].get("real_capture_options"), "photon.real_capture_options"
    )
    CAPTURE_OPTIONS = {
        d: CaptureOptions.from_dict(config["datasets"][d].get("captures"))
        for d in CAPTURES
    }
    CAPTURE_FILES = {
        d: capture_files(
            config["datasets"][d].get("path"),
            flat=config["datasets"][d].get("oracle") == "human",
        )
        for d in CAPTURES
    }
    for d, files in CAPTURE_FILES.items():
        # a cube with no timing stops the run here, not in a reconstruction job
        check_timing(
            config["datasets"][d]["path"],
            files,
            CAPTURE_OPTIONS[d],
            f"datasets.{d}.captures.bin_width_ps",
        )
        if workflow.exec_mode == ExecMode.DEFAULT:  # once, not in every job
            for line in not_read(config["datasets"][d]["path"]):
                logger.info(f"{d}: {line}")
    CAPTURE_SHARDS = {
        d: shard_count(CAPTURE_OPTIONS[d], len(f)) for d, f in CAPTURE_FILES.items()
    }
    # Datasets whose seed_labels list training rows: those rows are round 0's labels.
    SEED_LABELS_TRAIN = {
        d: lists_training_rows(config["datasets"][d]["seed_labels"])
        for d in HUMAN
        if Path(config["datasets"][d].get("seed_labels") or "-").is_file()
    }
except ValueError as err:
    sys.exit(f"Error: {err}")

# The plan, once per run (not in each cluster job); `jobs_line` follows it once the
# jobs are known (onstart). `snakemake -n` prints it without running anything.
# Then what changed since the last run into RESULTS, whose jobs that change reruns.
if workflow.exec_mode == ExecMode.DEFAULT:
    logger.info(plan_text(config, INHERITED))
    if older_results(f"{RESULTS}/config.yaml"):
        logger.info(OLDER_RESULTS.format(results=RESULTS))
    elif changed := changes_text(f"{RESULTS}/config.yaml", config):
        logger.info(changed)


def print_jobs_line():
    """The plan's last line, once the jobs are known (onstart of a local run)."""
    try:
        at_once = int(workflow.cores)
    except Exception:  # a run without --cores (a cluster): one estimate per job
        at_once = 1
    jobs = len(workflow.dag)
    # (imported here: it times each model, only when a run starts)
    from spl_al.bench.estimate import estimate_minutes

    settings = sum(
        bool(workflow.dag.reason(job).params_changed)
        for job in workflow.dag.needrun_jobs()
    )
    minutes = estimate_minutes(config, at_once) if jobs else None
    logger.info(jobs_line(jobs, RESULTS, minutes) + rerun_line(settings))


@functools.cache  # once per run: it names every file it leaves out
def real_capture_files():
    """{name: file} of the real captures to picture (none without a captures folder):
    every file of a capture format, read with photon.real_capture_options, named by
    its stem. A file of another format is named once, with the supported formats."""
    if REAL_CAPTURES is None:
        return {}
    if workflow.exec_mode == ExecMode.DEFAULT:  # once, not in every job
        for line in not_read(REAL_CAPTURES, recursive=False):
            logger.info(f"real captures: {line}")
    try:
        return picture_files(
            REAL_CAPTURES, PICTURE_OPTIONS, "photon.real_capture_options.bin_width_ps"
        )
    except ValueError as err:
        sys.exit(f"Error: {err}")


def photon_pictures():
    return [f"{RESULTS}/photon/conditions.png"] + expand(
        f"{RESULTS}/photon/real/{{capture}}.png", capture=list(real_capture_files())
    )


def capture_shards(dataset):
    return CAPTURE_SHARDS[dataset]


def capture_inputs(dataset, shard):
    """The capture files reconstruction shard ``shard`` of a captures dataset reads."""
    root = Path(config["datasets"][dataset]["path"])
    files = shard_of(CAPTURE_FILES[dataset], CAPTURE_SHARDS[dataset], shard)
    return [str(root / name) for name in files]


def capture_release(dataset):
    """The reconstructed release-layout folder of a captures dataset (none otherwise)."""
    return f"{RESULTS}/{dataset}/captures/release" if dataset in CAPTURES else []


def n_shards(dataset):
    return int(config["datasets"][dataset]["variants"]["shards"])


# The keys of a dataset entry its observed images do not depend on: the loop, the
# training and its precision, the methods' parameters, the variants (their own
# rules), the experiments, the embedding framework and the job sizes.
NOT_DATA = (
    "al",
    "train",
    "precision",
    "method_params",
    "variants",
    "experiments",
    "embedding",
    "robustness",
    "resources",
)


def dataset_params(dataset):
    """The dataset's config entry without the keys its data do not depend on
    (``NOT_DATA``): a change to them reruns nothing of the data."""
    entry = config["datasets"][dataset]
    return {key: value for key, value in entry.items() if key not in NOT_DATA}


def dataset_threads(wildcards):
    """Cores the dataset job uses: the synthesis's ``workers`` where the config sets
    them (1 synthesises in the job's own process), else 2."""
    entry = config["datasets"][wildcards.dataset]
    return int((entry.get("synthesis") or {}).get("workers") or 2)


def runs(dataset):
    """(method, seed) -> rounds for one dataset."""
    return dataset_runs(config, dataset)


def metrics_files(dataset, methods=None):
    """Every round's metrics of the dataset's runs (of ``methods`` only, when given)."""
    return [
        f"{RESULTS}/{dataset}/{method}/seed{seed}/round{r}/metrics.json"
        for (method, seed), rounds in sorted(runs(dataset).items())
        if methods is None or method in methods
        for r in range(rounds)
    ]


def budget_metrics_files(dataset):
    """The metrics the budget curves read: every run of the budget experiment's
    methods, not the sensitivity sweeps' (the curves plot those methods alone)."""
    budget = experiments_of(config, dataset, METHODS).get("budget") or {}
    return metrics_files(dataset, set(budget.get("methods", [])))


def round_file(wildcards, r, name):
    """File ``name`` of round ``r`` of the job's run (``RUN``)."""
    run = RUN.format(
        dataset=wildcards.dataset, method=wildcards.method, seed=wildcards.seed
    )
    return f"{run}/round{r}/{name}"


def labeled_in_round(wildcards, r):
    """Round 0 starts from the seed's shared initial set; round r from round r-1's
    query. With a human oracle every round's set, round 0's too, is the one whose
    labels were given (accept_labels)."""
    if r == 0 and wildcards.dataset not in HUMAN:
        return f"{RESULTS}/{wildcards.dataset}/initial/seed{wildcards.seed}.json"
    return round_file(wildcards, r, "labeled.json")


def initial_set_params(dataset):
    """What a seed's round-0 draw reads of the dataset's `al`: its size and whether it
    is stratified (not the batches or the ratio's denominator)."""
    al = config["datasets"][dataset]["al"]
    return {k: v for k, v in al.items() if k in ("initial", "stratified_initial")}


def labeled_input(wildcards):
    return labeled_in_round(wildcards, int(wildcards.round))


def initial_variants(wildcards):
    """Variants per group a method trains on (0: observed images only)."""
    method = dataset_method(config, wildcards.dataset, wildcards.method, METHODS)
    return method.train_variants(
        int(config["datasets"][wildcards.dataset]["variants"]["n"])
    )


def initial_fit(wildcards):
    """Round 0 of a simulated oracle is fitted and scored once per seed and variants
    per group (by train_initial): every method with the same start would train the
    same model.
    """
    if int(wildcards.round) != 0 or wildcards.dataset in HUMAN:
        return {}
    folder = f"{RESULTS}/{wildcards.dataset}/initial/seed{wildcards.seed}/m{initial_variants(wildcards)}"
    return {
        "initial_model": f"{folder}/model.pt",
        "initial_fit": f"{folder}/fit.json",
        "initial_scores": f"{folder}/scores.npz",
    }


def warm_start_model(wildcards):
    """Round r >= 1 fine-tunes the method's round r - 1 weights when the dataset's
    train.warm_start is set (its fit fields: fewer steps); else nothing."""
    train = config["datasets"][wildcards.dataset]["train"]
    if int(wildcards.round) == 0 or not train.get("warm_start"):
        return {}
    return {"previous_model": previous_round(wildcards, "model.pt")}


def previous_labeled(wildcards):
    """The labeled set round r - 1 trained on (query of round r adds to it)."""
    return labeled_in_round(wildcards, int(wildcards.round) - 1)


def given_labels(wildcards):
    """Labels a person gave for round r's training (none with a simulated oracle)."""
    if wildcards.dataset not in HUMAN:
        return []
    return round_file(wildcards, int(wildcards.round), "labels.npz")


def previous_round(wildcards, name):
    return round_file(wildcards, int(wildcards.round) - 1, name)


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
        "train": train_setup(config, wildcards.dataset),
        "method": method,
        "ratio_of": entry["al"].get("ratio_of", "train"),
    }


def queried_after(wildcards):
    """Whether a query reads round r's scores: not in a run's last round (a human
    oracle's rounds go on as long as labels come)."""
    if wildcards.dataset in HUMAN:
        return True
    rounds = runs(wildcards.dataset).get((wildcards.method, int(wildcards.seed)), 0)
    return int(wildcards.round) + 1 < rounds


def query_batch(wildcards):
    """Groups the query of round r adds: `al.batch`, or its entry r - 1 when it is a
    per-round list. A human oracle's rounds past the list (they go on as long as
    labels come) take its last entry."""
    return batch_of(
        config["datasets"][wildcards.dataset]["al"],
        int(wildcards.round),
        f"datasets.{wildcards.dataset}.al.batch",
        past_end=wildcards.dataset in HUMAN,
    )


def query_group(wildcards):
    """Query of round r + 1 runs in one submission with round r's train and score."""
    r = int(wildcards.round) - 1
    return f"round_{wildcards.dataset}_{wildcards.method}_{wildcards.seed}_{r}"


def has_levels(dataset):
    """Whether the dataset's images carry MSPPP levels: synthetic data and stand-ins do,
    a folder only when its files hold them or ``levels_file`` assigns them; captures get
    theirs from their own photons."""
    entry = config["datasets"][dataset]
    if entry["source"] == "captures":
        return True
    standin = entry["source"] == "folder" and not entry.get("path")
    if entry["source"] == "synthetic" or standin or entry.get("levels_file"):
        return True
    return folder_has_levels(entry["path"], entry.get("depth_key", "depth_ssp"))


NO_LEVELS_NOTE = (
    "files carry no MSPPP level; give `levels_file` to split by level "
    "(the per-level table and curves are skipped)"
)


def dataset_notes(dataset):
    """Notes of a dataset's summary: missing MSPPP levels, training steps that scale
    with images (its tables carry the latter too)."""
    notes = [] if has_levels(dataset) else [NO_LEVELS_NOTE]
    return notes + training_notes(config, dataset)


for _dataset in DATASETS:
    for _note in dataset_notes(_dataset):
        logger.info(f"{_dataset}: {_note}.")


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
        if has_levels(dataset):
            out += [f"{figures}/level_curves.{ext}" for ext in ("png", "pdf")]
        out += [f"{figures}/aubc.{ext}" for ext in ("png", "pdf")]
    if dataset_tables(dataset):
        out += [
            f"{tables}/{name}.{ext}"
            for name in ("comparisons", "claims")
            for ext in ("csv", "md")
        ]
    out += robustness_outputs(dataset)
    out += card_outputs(dataset) + export_outputs(dataset)
    return out


def dataset_tables(dataset):
    """The tables a dataset's experiments ask for (budget, levels, ablation,
    sensitivity); no levels table for images without MSPPP levels."""
    exps = config["datasets"][dataset].get("experiments", {})
    kinds = ("budget", "levels", "ablation", "sensitivity")
    return [t for t in kinds if t in exps and (t != "levels" or has_levels(dataset))]


# ---- human oracle (workflow/rules/human.smk)


def labels_dir(dataset):
    return config["datasets"][dataset].get("labels_dir") or f"labels/{dataset}"


def initial_labels_file(dataset, seed):
    """Round 0's labels: seed_labels when it lists training samples, else a file per seed."""
    given = config["datasets"][dataset].get("seed_labels")
    if given and SEED_LABELS_TRAIN.get(dataset, True):
        return given  # a missing file is reported by the dataset step, naming the key
    return f"{labels_dir(dataset)}/initial/seed{seed}.csv"


def labels_file(wildcards):
    """Where the person saves the filled to_label.csv of a round."""
    r = int(wildcards.round)
    if r == 0:
        return initial_labels_file(wildcards.dataset, wildcards.seed)
    return f"{labels_dir(wildcards.dataset)}/{wildcards.method}/seed{wildcards.seed}/round{r}.csv"


def initial_labels_export(dataset, seed):
    """Where round 0's Label Studio JSON export may be saved instead of its CSV."""
    return f"{labels_dir(dataset)}/initial/seed{seed}.json"


def labels_export(wildcards):
    """Where the person may save the batch's Label Studio JSON export instead."""
    r = int(wildcards.round)
    if r == 0:
        return initial_labels_export(wildcards.dataset, wildcards.seed)
    folder = labels_dir(wildcards.dataset)
    return f"{folder}/{wildcards.method}/seed{wildcards.seed}/round{r}.json"


def labels_file_if_given(wildcards):
    """The label files (CSV, Label Studio export) as inputs once they exist (so editing
    one reruns what follows); before that accept_labels runs without them and stops
    with a message naming them."""
    paths = (labels_file(wildcards), labels_export(wildcards))
    return [path for path in paths if Path(path).is_file()]


def batch_model(wildcards):
    """The model that chose round r's batch (round r - 1's): its predictions are the
    batch's Label Studio pre-annotations. Round 0's batch has none."""
    r = int(wildcards.round)
    return {"model": round_file(wildcards, r - 1, "model.pt")} if r > 0 else {}


def labeling_request(wildcards):
    """What round r asks labels for: round 0's set or round r's query."""
    if int(wildcards.round) == 0:
        return f"{RESULTS}/{wildcards.dataset}/initial/seed{wildcards.seed}.json"
    return round_file(wildcards, wildcards.round, "query.json")


def labeling_batch(wildcards):
    if int(wildcards.round) == 0:
        return f"{RESULTS}/{wildcards.dataset}/initial/seed{wildcards.seed}/to_label"
    return round_file(wildcards, wildcards.round, "to_label")


def labels_before(wildcards):
    r = int(wildcards.round)
    return [] if r == 0 else round_file(wildcards, r - 1, "labels.npz")


def sspi_args(flag=""):
    """Command-line options naming SSPI's weights when config photon.sspi_weights is set."""
    folder = config["photon"].get("sspi_weights")
    return f"{flag} --weights {shlex.quote(str(folder))}".strip() if folder else ""


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


def budget_experiment(dataset):
    return config["datasets"][dataset]["experiments"]["budget"]


def robustness_evals(wildcards):
    """The map's methods: the paper's family (its baselines and DUIS)."""
    return expand(
        f"{RESULTS}/{wildcards.dataset}/robustness/{{method}}.json",
        method=budget_families(config, wildcards.dataset, METHODS)["paper"],
    )


def final_models(wildcards):
    """The budget experiment's last-round models of this method, one per seed."""
    budget = budget_experiment(wildcards.dataset)
    last = int(budget["rounds"]) - 1
    return expand(
        f"{RESULTS}/{wildcards.dataset}/{wildcards.method}/seed{{seed}}/round{last}/model.pt",
        seed=budget["seeds"],
    )


def robustness_outputs(dataset):
    if robustness_grid(dataset) is None:
        return []
    return [
        f"{RESULTS}/{dataset}/tables/robustness.csv",
        f"{RESULTS}/{dataset}/tables/robustness_diff.csv",
        f"{RESULTS}/{dataset}/figures/robustness.png",
        f"{RESULTS}/{dataset}/figures/robustness_diff.png",
    ]


# Warm job processes (workflow/rules/warm.smk) and the scripts they run.

# (not named `conda`: that word opens a rule directive for Snakemake's parser)
PER_RULE_ENVS = DeploymentMethod.CONDA in workflow.deployment_settings.deployment_method
# A job finds its Python (this run's own, or its rule's conda environment's), the job
# client and the scripts through the environment, which Snakemake's jobs inherit (a
# cluster job parses this file again and sets them there): a rule's command, which
# Snakemake's "code changed" trigger compares, names no path of this checkout or
# Python, and uses nothing from outside its rule (snakemake --lint).
# (set here, not read from the user: no `envvars:` entry)
os.environ.update(
    SPL_AL_PYTHON="python" if PER_RULE_ENVS else sys.executable,
    SPL_AL_JOB_CLIENT=warm_client.__file__,
    SPL_AL_SCRIPTS=str(Path(workflow.basedir) / "workflow" / "scripts"),
)


def python_job(script):
    """The shell command that runs workflow/scripts/SCRIPT.py as a job. The warm
    client (spl_al/warm/client.py, standard library only, so the job's own
    process starts in ~0.03 CPU-s instead of the ~0.25 of Snakemake's `script:`)
    hands the script to the warm server, or runs it itself without one. The script
    reads its job from `snakemake` as usual; the rule's params must be
    `job=job_params(...)` (the settings) and `files=job_files` (the paths)."""
    return (
        '"$SPL_AL_PYTHON" -S -P "$SPL_AL_JOB_CLIENT"'
        f' "$SPL_AL_SCRIPTS/{script}.py"'
        " {log:q} {threads} {params.files:q} {params.job:q}"
    )


def job_params(**params):
    """The `params: job=job_params(NAME=VALUE, ...)` that `python_job` needs: every
    setting the job reads. Each value, or function of the job's wildcards, is evaluated
    for the job into one dict of plain values, which the script reads back as
    `snakemake.params.NAME`. A function of the wildcards alone, so Snakemake records
    the dict and its params trigger reruns the job when a setting changes (it leaves
    out params computed from input or output)."""

    def job(wildcards):
        return warm_client.job_settings(
            {
                name: value(wildcards) if callable(value) else value
                for name, value in params.items()
            }
        )

    return job


def job_files(wildcards, input, output):
    """The `params: files=job_files` that `python_job` needs: the job's named input and
    output files and its wildcards, for `snakemake.input.NAME`, ... (Snakemake tracks
    the files themselves)."""
    return warm_client.files_text(input, output, wildcards)


_warm = {}


def start_warm_worker():
    enabled = (
        config.get("warm_worker", True) and workflow.local_exec and not PER_RULE_ENVS
    )
    server = Server.for_run(f"{RESULTS}/logs/warm_server.log", enabled=enabled)
    if server:
        _warm["server"] = server


def stop_warm_worker():
    if "server" in _warm:
        _warm.pop("server").stop()


# Model cards and ONNX export (workflow/rules/deploy.smk).


def final_round(wildcards):
    """The round whose model is a run's final one: the last round its experiments run;
    with a human oracle the last round whose labels were given so far (its label file
    or Label Studio export exists)."""
    if wildcards.dataset in HUMAN:
        from types import SimpleNamespace

        def given(r):
            w = SimpleNamespace(
                dataset=wildcards.dataset,
                method=wildcards.method,
                seed=wildcards.seed,
                round=str(r),
            )
            return bool(labels_file_if_given(w))

        r = 0
        while given(r + 1):
            r += 1
        return r
    return runs(wildcards.dataset)[(wildcards.method, int(wildcards.seed))] - 1


def final_file(wildcards, name):
    return round_file(wildcards, final_round(wildcards), name)


def card_inputs(wildcards):
    """What a round's card reads: its model, metrics and labeled set, the dataset, and
    the method's robustness map when the run has one for this round."""
    r = int(wildcards.round)
    files = {
        "model": round_file(wildcards, r, "model.pt"),
        "metrics": round_file(wildcards, r, "metrics.json"),
        "labeled": labeled_in_round(wildcards, r),
        "data": f"{RESULTS}/{wildcards.dataset}/data/dataset.npz",
    }
    grid = robustness_grid(wildcards.dataset)
    family = budget_families(config, wildcards.dataset, METHODS)["paper"]
    if grid is not None and wildcards.method in family:
        budget = budget_experiment(wildcards.dataset)
        if r == int(budget["rounds"]) - 1 and int(wildcards.seed) in budget["seeds"]:
            files["robustness"] = (
                f"{RESULTS}/{wildcards.dataset}/robustness/{wildcards.method}.json"
            )
    return files


def card_facts(wildcards):
    """The RunFacts of a round's card: names, training setup, how raw captures are
    reconstructed for this dataset, and the config the model depends on."""
    entry = config["datasets"][wildcards.dataset]
    method = dataset_method(config, wildcards.dataset, wildcards.method, METHODS)
    if entry["source"] == "captures":
        reconstruction = {"method": "pooled", **(entry.get("captures") or {})}
    else:
        reconstruction = {"method": "pooled"}
    setup = train_setup(config, wildcards.dataset)
    return {
        "dataset": wildcards.dataset,
        "method": wildcards.method,
        "seed": int(wildcards.seed),
        "round": int(wildcards.round),
        "train": setup,
        "strategy": method.strategy,
        "method_params": dict(method.params),
        "reconstruction": reconstruction,
        "config": {
            "dataset": dataset_params(wildcards.dataset),
            "method": method.as_dict(),
        },
    }


def exportable(dataset):
    """Whether a dataset's models export to ONNX (``NOT_EXPORTED``: PointNet++'s do not)."""
    return train_setup(config, dataset)["model"].get("arch") not in NOT_EXPORTED


def card_outputs(dataset):
    """The model cards beside the budget experiment's final-round models: of every
    method (``export.cards: all``) or of the exported methods only (``exported``)."""
    budget = experiments_of(config, dataset).get("budget")
    if not budget:
        return []
    export = config.get("export") or {}
    methods = budget["methods"]
    if export.get("cards", "all") == "exported":
        methods = [m for m in methods if m in export.get("methods", [])]
    last = int(budget["rounds"]) - 1
    return [
        f"{RESULTS}/{dataset}/{method}/seed{seed}/round{last}/model.card.{ext}"
        for method in methods
        for seed in budget["seeds"]
        for ext in ("json", "md")
    ]


def export_outputs(dataset):
    """final.onnx and its card of every exported method's budget seeds."""
    methods = (config.get("export") or {}).get("methods", [])
    budget = experiments_of(config, dataset).get("budget")
    if not budget or not exportable(dataset):
        return []
    chosen = [m for m in budget["methods"] if m in methods]
    return [
        f"{RESULTS}/{dataset}/models/{method}/seed{seed}/final.{ext}"
        for method in chosen
        for seed in budget["seeds"]
        for ext in ("onnx", "card.json", "card.md")
    ]

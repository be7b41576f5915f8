# What the rule files share; each file's own functions are in workflow/rules/functions/
import functools
import os
import sys
from pathlib import Path

from snakemake.logging import logger
from snakemake.settings.types import DeploymentMethod, ExecMode

from spl_al.config import dataset_precision, train_setup, training_notes
from spl_al.data.sources import has_levels as source_has_levels, source_kind
from spl_al.frameworks import (
    EMBEDDING as EMBEDDING_FRAMEWORK,
    SUPERVISED,
    get_feature_space,
)
from spl_al import layout
from spl_al.warm import client as warm_client
from spl_al.experiment.overview import jobs_line, plan_text
from spl_al.report.table_kinds import TABLE_KINDS, table_names
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
    encoder_read,
    experiments_of,
    method_specs,
    sweep_table_spec,
)

RESULTS = config["results"]


DATASETS = list(config["datasets"])


METHODS = method_specs(config)


RUN = layout.run_folder(RESULTS, "{dataset}", "{method}", "{seed}")


# A dataset's data files (spl_al.layout): its sample groups and its observed images.
DATASET_FILE = layout.data_file(RESULTS, "{dataset}")
OBSERVED_FILE = layout.data_file(RESULTS, "{dataset}", "observed.npz")
# The supervised framework's folder of a dataset: its tables and figures go under it.
SUPERVISED_DIR = SUPERVISED.folder(RESULTS, "{dataset}")


# Datasets whose labels come from a person (oracle: human) and from the data.
HUMAN = [d for d in DATASETS if config["datasets"][d].get("oracle") == "human"]


SIMULATED = [d for d in DATASETS if d not in HUMAN]


# Datasets made from raw photon captures (workflow/rules/captures.smk): their source
# reads the folder that rule captures_release makes.
CAPTURES = [
    d
    for d in DATASETS
    if source_kind(config["datasets"][d]["source"]).release_rule == "captures_release"
]


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
    EMBEDDING_FRAMEWORK.block,
    "robustness",
    "resources",
)


def dataset_params(dataset):
    """The dataset's config entry without the keys its data do not depend on
    (``NOT_DATA``): a change to them reruns nothing of the data."""
    entry = config["datasets"][dataset]
    return {key: value for key, value in entry.items() if key not in NOT_DATA}


@functools.cache
def runs(dataset):
    """(method, seed) -> rounds for one dataset (once per dataset: every job's input
    functions ask; read it, do not change it)."""
    return dataset_runs(config, dataset)


def round_file(wildcards, r, name):
    """File ``name`` of round ``r`` of the job's run (``RUN``)."""
    run = RUN.format(
        dataset=wildcards.dataset, method=wildcards.method, seed=wildcards.seed
    )
    return layout.round_file(run, r, name)


def labeled_in_round(wildcards, r):
    """Round 0 starts from the seed's shared initial set; round r from round r-1's
    query. With a human oracle every round's set, round 0's too, is the one whose
    labels were given (accept_labels)."""
    if r == 0 and wildcards.dataset not in HUMAN:
        return f"{initial_folder(wildcards)}/seed{wildcards.seed}.json"
    return round_file(wildcards, r, "labeled.json")


def has_levels(dataset):
    """Whether the dataset's images carry MSPPP levels (its source's trait, else its
    files: spl_al.data.sources.has_levels)."""
    return source_has_levels(config["datasets"][dataset])


# How a job runs its script (the warm client), with its settings and files.

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

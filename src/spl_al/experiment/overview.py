"""The plan of a run, printed before its first job (no torch, no data read: cheap to import).

Per dataset: its source, image shape, task and oracle, and per experiment the methods,
seeds, rounds and labeled budgets; which keys a dataset took from config/config.yaml
when ``only_datasets`` reuses a default's name; the results folder. The workflow prints
``plan_text`` when it reads its config and ``jobs_line`` once Snakemake knows the jobs.
"""

from __future__ import annotations

from spl_al.config import is_standin
from spl_al.data.sources import is_synthesised, source_kind
from spl_al.experiment.encoders import encoder_seeds
from spl_al.experiment.plan import experiments_of, labeled_at, sweep_table_spec
from spl_al.frameworks import EMBEDDING
from spl_al.report.table_kinds import TABLE_KINDS, TableContext

DEFAULT_SHAPES = {"classification": (64, 64), "segmentation": (64, 256)}
"""Image shape of the synthetic generators when ``synthesis.image_shape`` is unset."""


def image_shape(entry: dict) -> str:
    """What shape a dataset's images take, in words."""
    shape = (entry.get("synthesis") or {}).get("image_shape")
    if is_synthesised(entry):
        rows, cols = shape or DEFAULT_SHAPES.get(entry.get("task"), ("?", "?"))
        return f"{rows}x{cols} images"
    what = source_kind(entry.get("source")).images
    if shape:
        return f"images resized to {shape[0]}x{shape[1]} (synthesis.image_shape)"
    return f"images as the {what} give them"


def _source(entry: dict) -> str:
    source = entry.get("source")
    if is_standin(entry):
        return "folder (not set: a synthetic stand-in)"
    if entry.get("path"):
        return f"{source} {entry['path']}"
    return str(source)


def dataset_lines(config: dict, dataset: str) -> list[str]:
    """The plan's lines of one dataset."""
    entry = config["datasets"][dataset]
    human = entry.get("oracle") == "human"
    oracle = "labels from you (oracle: human)" if human else "simulated oracle"
    lines = [
        f"{dataset}: {entry.get('task')}, source {_source(entry)}, {image_shape(entry)}, {oracle}"
    ]
    lines += _experiment_lines(config, dataset, experiments_of(config, dataset), human)
    embedding = EMBEDDING.settings(entry)
    if EMBEDDING.enabled(entry):
        steps = (embedding.get("encoder") or {}).get("steps", 300)
        k = len(encoder_seeds(entry))
        block = (embedding.get("encoder") or {}).get("block")
        encoders = (
            f"{k} self-supervised encoders of {steps} steps, run seed s reading number "
            f"(s - 1) // {block}, statistics over the encoders"
            if k > 1
            else f"one self-supervised encoder of {steps} steps"
        )
        lines.append(
            f"  {EMBEDDING.name} framework (a linear classifier on frozen embeddings; "
            f"{encoders}; results in {EMBEDDING.folder('...', dataset)}/):"
        )
        exps = experiments_of(config, dataset, framework=EMBEDDING)
        lines += ["  " + line for line in _experiment_lines(config, dataset, exps, human)]
    return lines


def _experiment_lines(config: dict, dataset: str, exps: dict, human: bool) -> list[str]:
    entry = config["datasets"][dataset]
    m = int((entry.get("variants") or {}).get("n", 4))
    ctx = TableContext(
        exps,
        sweep_table_spec(config, m),
        labeled=lambda r: labeled_at(entry["al"], r),
        human=human,
    )
    return [
        "  " + kind.describe(exps[name], ctx)
        for name, kind in TABLE_KINDS.items()
        if exps.get(name)
    ]


def plan_text(config: dict, inherited: dict | None = None) -> str:
    """The plan of a run of ``config`` (merged and checked): a few lines per dataset.

    ``inherited`` (``spl_al.config.select_datasets``) lists per dataset the keys it
    took from config/config.yaml; each is named with its value.
    """
    names = list(config["datasets"])
    how = "only_datasets" if config.get("only_datasets") else "config/config.yaml + overrides"
    lines = [f"Plan: {len(names)} dataset(s) ({how}), results in {config['results']}/"]
    for dataset in names:
        lines += ["  " + line for line in dataset_lines(config, dataset)]
        taken = (inherited or {}).get(dataset)
        if taken:
            keys = ", ".join(f"{key}={value!r}" for key, value in taken.items())
            lines.append(
                f"    inherits from config/config.yaml's {dataset} ({len(taken)} keys, give "
                f"them or use a name of your own): {keys}"
            )
    return "\n".join(lines)


def jobs_line(n_jobs: int, results: str, minutes: float | None = None) -> str:
    """The plan's last line: the jobs to run, and the predicted time of the whole config
    from scratch on this machine when there is one."""
    time = (
        f"; the whole config takes about {minutes:.0f} min from scratch here "
        "(python -m spl_al.bench estimate)"
        if minutes
        else ""
    )
    return f"Plan: {n_jobs} jobs to run{time}; results in {results}/"

"""Where a run's files lie in its results folder: the one home of the files that the
workflow writes and something else reads back (the library's steps, the benches, the
docs generators). A job's own working files (logs, benchmarks, the round-0 fits under
``initial*/``, a round's query and labeling batch, the embedding framework's runs) are
named in the rule that writes them.

```
{results}/{dataset}/data/{dataset.npz, observed.npz, variants/}
{results}/{dataset}/initial[_{start}]/seed{seed}.json           round 0's labeled set
{results}/{dataset}/{method}/seed{seed}/round{r}/{labeled.json, model.pt, metrics.json, scores.npz}
{folder}/tables/{name}, {folder}/figures/{name}                 a framework's folder
{folder}/encoders/seed{eseed}/{encoder.pt, card.json, embeddings.npz}   an encoder's
```

A framework's folder is ``results/{dataset}`` or a subfolder of it
(``spl_al.frameworks.FrameworkKind.folder``). Each function takes the results folder
as a string or path and returns a string, so a wildcard (``"{dataset}"``) passes
through for the workflow's patterns.
"""

from __future__ import annotations

INITIAL = "initial"
"""The folder of the round-0 sets drawn by the dataset's own ``al.initial_strategy``."""


def data_file(results, dataset: str, name: str = "dataset.npz") -> str:
    """A dataset's data file: ``dataset.npz`` (the sample groups), ``observed.npz``."""
    return f"{results}/{dataset}/data/{name}"


def initial_folder(start: str | None = None) -> str:
    """``initial``, or ``initial_{start}`` for the round 0 a cold start ``start`` chose
    for the cold-start experiment's arms (``spl_al.cold_start``)."""
    return INITIAL if start is None else f"{INITIAL}_{start}"


def initial_file(results, dataset: str, seed, start: str | None = None) -> str:
    """Round 0's labeled set of a seed (``initial_folder``)."""
    return f"{results}/{dataset}/{initial_folder(start)}/seed{seed}.json"


def run_folder(results, dataset: str, method: str, seed) -> str:
    """The folder of one (method, seed) run of the supervised framework."""
    return f"{results}/{dataset}/{method}/seed{seed}"


def round_file(run, round_, name: str) -> str:
    """File ``name`` of round ``round_`` of a run (``run_folder``): labeled.json,
    model.pt, metrics.json, scores.npz."""
    return f"{run}/round{round_}/{name}"


def table_file(folder, name: str) -> str:
    """A table of a framework's folder: ``budget.csv``, ``summary.json``, ..."""
    return f"{folder}/tables/{name}"


def figure_file(folder, name: str) -> str:
    """A figure of a framework's folder: ``curves.png``, ..."""
    return f"{folder}/figures/{name}"


ENCODER_FILES = ENCODER_WEIGHTS, ENCODER_CARD, ENCODER_EMBEDDINGS = (
    "encoder.pt",
    "card.json",
    "embeddings.npz",
)
"""An encoder's files, side by side: its weights, its card and the embeddings the runs
read."""


def encoder_file(folder, eseed, name: str) -> str:
    """File ``name`` (``ENCODER_FILES``) of the encoder of seed ``eseed`` of an
    embedding framework's folder."""
    if name not in ENCODER_FILES:
        raise ValueError(f"an encoder's files are {list(ENCODER_FILES)}, not {name!r}.")
    return f"{folder}/encoders/seed{eseed}/{name}"

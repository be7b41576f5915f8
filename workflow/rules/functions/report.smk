# Input functions of workflow/rules/report.smk and the outputs `all` asks of a dataset.
from spl_al.experiment.outputs import framework_outputs


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


def budget_block(dataset, framework=SUPERVISED):
    """The budget experiment of the dataset in ``framework`` as run ({} without one)."""
    return experiments_of(config, dataset, METHODS, framework).get("budget") or {}


def batch_runs(dataset):
    """[method, seed, rounds] of every budget run whose queried frames
    batch_conditions counts: the budget's methods and seeds, up to its rounds."""
    budget = budget_block(dataset)
    methods, seeds = budget.get("methods", []), set(budget.get("seeds", []))
    return [
        [method, seed, min(rounds, int(budget["rounds"]))]
        for (method, seed), rounds in sorted(runs(dataset).items())
        if method in methods and seed in seeds
    ]


def batch_labeled_files(dataset):
    """Each run's labeled set at each round (round 0 first), in the order of
    batch_runs: what the frames each query round added are read from."""
    from types import SimpleNamespace

    files = []
    for method, seed, rounds in batch_runs(dataset):
        w = SimpleNamespace(dataset=dataset, method=method, seed=str(seed))
        files += [labeled_in_round(w, r) for r in range(rounds)]
    return files


def dataset_outputs(dataset):
    """What `all` asks of a dataset: its pictures, the supervised framework's outputs
    (spl_al.experiment.outputs), robustness maps, model cards and exports."""
    folder = SUPERVISED.folder(RESULTS, dataset)
    out = [
        layout.figure_file(folder, "contact_sheet.png"),
        layout.figure_file(folder, "variants_sheet.png"),
    ]
    out += framework_outputs(config, dataset, SUPERVISED, results=RESULTS)
    out += robustness_outputs(dataset)
    out += card_outputs(dataset) + export_outputs(dataset)
    return out


def dataset_tables(dataset):
    """The tables a dataset's experiments ask for (spl_al.report.table_kinds); none
    that needs MSPPP levels for images without them."""
    exps = SUPERVISED.experiments(config["datasets"][dataset])
    return table_names(exps, has_levels=has_levels(dataset))


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

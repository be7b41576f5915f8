# Input functions of workflow/rules/report.smk and the outputs `all` asks of a dataset.


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


def dataset_outputs(dataset):
    tables = f"{RESULTS}/{dataset}/tables"
    figures = f"{RESULTS}/{dataset}/figures"
    out = [f"{figures}/contact_sheet.png", f"{figures}/variants_sheet.png"]
    if runs(
        dataset
    ):  # a dataset in the embedding framework alone has no supervised run
        out.append(f"{tables}/summary.json")
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
    """The tables a dataset's experiments ask for (spl_al.report.table_kinds); none
    that needs MSPPP levels for images without them."""
    exps = config["datasets"][dataset].get("experiments", {})
    return table_names(exps, has_levels=has_levels(dataset))

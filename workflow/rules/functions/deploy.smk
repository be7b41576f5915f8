# Input functions of workflow/rules/deploy.smk: model cards and ONNX export.
from spl_al.deploy.export import NOT_EXPORTED


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
        "data": layout.data_file(RESULTS, wildcards.dataset),
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

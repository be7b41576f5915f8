# Input functions of workflow/rules/robustness.smk: the condition robustness map.


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
    folder = SUPERVISED.folder(RESULTS, dataset)
    return [
        layout.table_file(folder, "robustness.csv"),
        layout.table_file(folder, "robustness_diff.csv"),
        layout.figure_file(folder, "robustness.png"),
        layout.figure_file(folder, "robustness_diff.png"),
    ]

# Input functions of workflow/rules/data.smk.


def n_shards(dataset):
    return int(config["datasets"][dataset]["variants"]["shards"])


def dataset_threads(wildcards):
    """Cores the dataset job uses: the synthesis's ``workers`` where the config sets
    them (1 synthesises in the job's own process), else 2."""
    entry = config["datasets"][wildcards.dataset]
    return int((entry.get("synthesis") or {}).get("workers") or 2)

# Input functions of workflow/rules/embedding.smk: the embedding framework.


# Datasets with an encoder: an embedding framework, or a method selecting on it.
EMBEDDED = [
    d
    for d in DATASETS
    if config["datasets"][d].get("embedding") or selects_on_embedding(d)
]
EMBEDDING = f"{RESULTS}/{{dataset}}/embedding"


def embedding_entry(dataset):
    return config["datasets"][dataset].get("embedding") or {}


def probe_runs_files(dataset, methods=None):
    """The runs file of every method the dataset's embedding experiments run."""
    names = {m for m, _seed in dataset_runs(config, dataset, "embedding")}
    return [
        f"{RESULTS}/{dataset}/embedding/runs/{m}.json"
        for m in sorted(names)
        if methods is None or m in methods
    ]


def probe_run_params(wildcards):
    """Seeds and rounds of one method's runs (the longest any experiment needs)."""
    runs = dataset_runs(config, wildcards.dataset, "embedding")
    seeds = sorted(s for m, s in runs if m == wildcards.method)
    rounds = max(r for (m, _s), r in runs.items() if m == wildcards.method)
    return {"seeds": seeds, "rounds": rounds}


def embedding_outputs(dataset):
    """What `all` asks of a dataset's embedding framework."""
    if dataset not in EMBEDDED:
        return []
    exps = embedding_entry(dataset).get("experiments") or {}
    base = f"{RESULTS}/{dataset}/embedding"
    kinds = table_names(exps, has_levels=has_levels(dataset))
    out = [f"{base}/tables/{t}.{ext}" for t in kinds for ext in ("csv", "md", "tex")]
    out += [f"{base}/tables/summary.json", f"{base}/encoder.card.json"]
    if "budget" in exps:
        out += [f"{base}/figures/curves.{ext}" for ext in ("png", "pdf")]
        out += [f"{base}/figures/aubc.{ext}" for ext in ("png", "pdf")]
        if has_levels(dataset):
            out += [f"{base}/figures/level_curves.{ext}" for ext in ("png", "pdf")]
    if kinds:
        out += [
            f"{base}/tables/{name}.{ext}"
            for name in ("comparisons", "claims", "decomposition")
            for ext in ("csv", "md")
        ]
    return out

# Input functions of workflow/rules/embedding.smk: the embedding framework.

from spl_al.experiment.encoders import encoder_of, encoder_recipe, encoder_seeds
from spl_al.report.claims import encoder_claim_notes

# Datasets with an encoder: an embedding framework, or a method selecting on it.
EMBEDDED = [
    d
    for d in DATASETS
    if config["datasets"][d].get("embedding") or selects_on_embedding(d)
]
EMBEDDING = f"{RESULTS}/{{dataset}}/embedding"


def embedding_entry(dataset):
    return config["datasets"][dataset].get("embedding") or {}


def encoder_file(dataset, eseed, name):
    """One of encoder ``eseed``'s files: encoder.pt, card.json or embeddings.npz."""
    return f"{RESULTS}/{dataset}/embedding/encoders/seed{eseed}/{name}"


def run_encoders(wildcards):
    """Run seed -> encoder seed of one method's runs."""
    entry = config["datasets"][wildcards.dataset]
    return {s: encoder_of(entry, s) for s in probe_run_params(wildcards)["seeds"]}


def probe_runs_encoders(wildcards):
    """The embeddings and cards of the encoders one method's runs read."""
    eseeds = sorted(set(run_encoders(wildcards).values()))
    return {
        "embeddings": [
            encoder_file(wildcards.dataset, e, "embeddings.npz") for e in eseeds
        ],
        "cards": [encoder_file(wildcards.dataset, e, "card.json") for e in eseeds],
    }


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
    # no experiments (an encoder for a cold start alone): no runs to summarise
    out += [f"{base}/tables/summary.json"] if kinds else []
    out += [
        encoder_file(dataset, e, "card.json")
        for e in encoder_seeds(config["datasets"][dataset])
    ]
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

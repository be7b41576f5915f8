# Input functions of workflow/rules/embedding.smk: the embedding framework.

from spl_al.experiment.encoders import encoder_of, encoder_recipe, encoder_seeds
from spl_al.report.claims import encoder_claim_notes

# Datasets with an encoder: an embedding framework, or a method selecting on it.
EMBEDDED = [
    d
    for d in DATASETS
    if EMBEDDING_FRAMEWORK.enabled(config["datasets"][d]) or selects_on_embedding(d)
]
# Those that draw their own encoders and runs; the others share a dataset's
# (`embedding: {shared: SOURCE}`, SHARED_EMBEDDING: the Snakefile's).
OWN_EMBEDDED = [d for d in EMBEDDED if d not in SHARED_EMBEDDING]
# The framework's folders, with the dataset a wildcard: outputs, logs, benchmarks.
EMBEDDING = EMBEDDING_FRAMEWORK.folder(RESULTS, "{dataset}")
EMBEDDING_LOGS = EMBEDDING_FRAMEWORK.folder(f"{RESULTS}/logs", "{dataset}")
EMBEDDING_BENCHMARKS = EMBEDDING_FRAMEWORK.folder(f"{RESULTS}/benchmarks", "{dataset}")


def embedding_entry(dataset):
    return EMBEDDING_FRAMEWORK.settings(config["datasets"][dataset])


def encoder_file(dataset, eseed, name):
    """One of encoder ``eseed``'s files: encoder.pt, card.json or embeddings.npz (a
    dataset that shares another's embedding framework reads that one's encoders)."""
    owner = SHARED_EMBEDDING.get(dataset, dataset)
    return layout.encoder_file(EMBEDDING_FRAMEWORK.folder(RESULTS, owner), eseed, name)


@functools.cache
def embedding_runs(dataset):
    """(method, seed) -> rounds of the dataset's embedding framework (once per dataset:
    each probe_runs job's params ask; read it, do not change it)."""
    return dataset_runs(config, dataset, EMBEDDING_FRAMEWORK)


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
    names = {m for m, _seed in embedding_runs(dataset)}
    return [
        f"{EMBEDDING_FRAMEWORK.folder(RESULTS, dataset)}/runs/{m}.json"
        for m in sorted(names)
        if methods is None or m in methods
    ]


def probe_run_params(wildcards):
    """Seeds and rounds of one method's runs (the longest any experiment needs)."""
    runs = embedding_runs(wildcards.dataset)
    seeds = sorted(s for m, s in runs if m == wildcards.method)
    rounds = max(r for (m, _s), r in runs.items() if m == wildcards.method)
    return {"seeds": seeds, "rounds": rounds}


def embedding_outputs(dataset):
    """What `all` asks of a dataset's embedding framework (spl_al.experiment.outputs)
    and its encoders' cards."""
    if dataset not in EMBEDDED:
        return []
    out = framework_outputs(config, dataset, EMBEDDING_FRAMEWORK, results=RESULTS)
    return out + [
        encoder_file(dataset, e, "card.json")
        for e in encoder_seeds(config["datasets"][dataset])
    ]


def shared_runs_inputs(wildcards):
    """The source's runs file of the method, and both datasets' files (the job checks
    that they hold the same scans)."""
    source = SHARED_EMBEDDING[wildcards.dataset]
    return {
        "runs": f"{EMBEDDING_FRAMEWORK.folder(RESULTS, source)}/runs/{wildcards.method}.json",
        "data": layout.data_file(RESULTS, wildcards.dataset),
        "source_data": layout.data_file(RESULTS, source),
    }

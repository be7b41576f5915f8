# Input functions of workflow/rules/human.smk: the label files a person fills.
from spl_al.data.label_files import lists_training_rows

try:
    # Datasets whose seed_labels list training rows: those rows are round 0's labels.
    SEED_LABELS_TRAIN = {
        d: lists_training_rows(config["datasets"][d]["seed_labels"])
        for d in HUMAN
        if Path(config["datasets"][d].get("seed_labels") or "-").is_file()
    }
except ValueError as err:
    sys.exit(f"Error: {err}")


def labels_dir(dataset):
    return config["datasets"][dataset].get("labels_dir") or f"labels/{dataset}"


def initial_labels_file(dataset, seed):
    """Round 0's labels: seed_labels when it lists training samples, else a file per seed."""
    given = config["datasets"][dataset].get("seed_labels")
    if given and SEED_LABELS_TRAIN.get(dataset, True):
        return given  # a missing file is reported by the dataset step, naming the key
    return f"{labels_dir(dataset)}/initial/seed{seed}.csv"


def labels_file(wildcards):
    """Where the person saves the filled to_label.csv of a round."""
    r = int(wildcards.round)
    if r == 0:
        return initial_labels_file(wildcards.dataset, wildcards.seed)
    return f"{labels_dir(wildcards.dataset)}/{wildcards.method}/seed{wildcards.seed}/round{r}.csv"


def initial_labels_export(dataset, seed):
    """Where round 0's Label Studio JSON export may be saved instead of its CSV."""
    return f"{labels_dir(dataset)}/initial/seed{seed}.json"


def labels_export(wildcards):
    """Where the person may save the batch's Label Studio JSON export instead."""
    r = int(wildcards.round)
    if r == 0:
        return initial_labels_export(wildcards.dataset, wildcards.seed)
    folder = labels_dir(wildcards.dataset)
    return f"{folder}/{wildcards.method}/seed{wildcards.seed}/round{r}.json"


def labels_file_if_given(wildcards):
    """The label files (CSV, Label Studio export) as inputs once they exist (so editing
    one reruns what follows); before that accept_labels runs without them and stops
    with a message naming them."""
    paths = (labels_file(wildcards), labels_export(wildcards))
    return [path for path in paths if Path(path).is_file()]


def batch_model(wildcards):
    """The model that chose round r's batch (round r - 1's): its predictions are the
    batch's Label Studio pre-annotations. Round 0's batch has none."""
    r = int(wildcards.round)
    return {"model": round_file(wildcards, r - 1, "model.pt")} if r > 0 else {}


def labeling_request(wildcards):
    """What round r asks labels for: round 0's set or round r's query."""
    if int(wildcards.round) == 0:
        return f"{RESULTS}/{wildcards.dataset}/initial/seed{wildcards.seed}.json"
    return round_file(wildcards, wildcards.round, "query.json")


def labeling_batch(wildcards):
    if int(wildcards.round) == 0:
        return f"{RESULTS}/{wildcards.dataset}/initial/seed{wildcards.seed}/to_label"
    return round_file(wildcards, wildcards.round, "to_label")


def labels_before(wildcards):
    r = int(wildcards.round)
    return [] if r == 0 else round_file(wildcards, r - 1, "labels.npz")

# Input functions of workflow/rules/al.smk: a round's files and settings.
from spl_al.cold_start import COLD_START, initial_strategy, is_cold_start
from spl_al.experiment.plan import round0_start

# Folders of round-0 sets: initial/ (the dataset's al.initial_strategy) and initial_{S}/
# (the round 0 that cold-start strategy S chooses for the cold-start experiment's arms).
INITIAL_DIRS = layout.INITIAL + r"(_(" + "|".join(COLD_START) + "))?"


def initial_set_params(dataset, folder=layout.INITIAL):
    """What a seed's round-0 draw reads of the dataset's `al`: its size and how it is
    chosen (not the batches or the ratio's denominator). `folder`: initial_{S} holds
    the round 0 that S chooses for a cold-start arm."""
    al = config["datasets"][dataset]["al"]
    keys = ("initial", "stratified_initial", "initial_strategy")
    if folder != layout.INITIAL:
        return {
            "initial": al["initial"],
            "initial_strategy": folder.removeprefix(f"{layout.INITIAL}_"),
        }
    return {k: v for k, v in al.items() if k in keys}


def initial_embeddings(wildcards):
    """A cold start's input: the embeddings of the run seed's encoder."""
    folder = getattr(wildcards, "initial_dir", layout.INITIAL)
    al = initial_set_params(wildcards.dataset, folder)
    if not is_cold_start(initial_strategy(al)):
        return {}
    entry = config["datasets"][wildcards.dataset]
    eseed = encoder_of(entry, int(wildcards.seed))
    return {"embeddings": encoder_file(wildcards.dataset, eseed, "embeddings.npz")}


def labeled_input(wildcards):
    return labeled_in_round(wildcards, int(wildcards.round))


def initial_variants(wildcards):
    """Variants per group a method trains on (0: observed images only)."""
    method = dataset_method(config, wildcards.dataset, wildcards.method, METHODS)
    return method.train_variants(
        int(config["datasets"][wildcards.dataset]["variants"]["n"])
    )


def initial_fit(wildcards):
    """Round 0 of a simulated oracle is fitted and scored once per seed and variants
    per group (by train_initial): every method with the same start would train the
    same model.
    """
    if int(wildcards.round) != 0 or wildcards.dataset in HUMAN:
        return {}
    folder = f"{initial_folder(wildcards)}/seed{wildcards.seed}/m{initial_variants(wildcards)}"
    return {
        "initial_model": f"{folder}/model.pt",
        "initial_fit": f"{folder}/fit.json",
        "initial_scores": f"{folder}/scores.npz",
    }


def warm_start_model(wildcards):
    """Round r >= 1 fine-tunes the method's round r - 1 weights when the dataset's
    train.warm_start is set (its fit fields: fewer steps); else nothing."""
    train = config["datasets"][wildcards.dataset]["train"]
    if int(wildcards.round) == 0 or not train.get("warm_start"):
        return {}
    return {"previous_model": previous_round(wildcards, "model.pt")}


def previous_labeled(wildcards):
    """The labeled set round r - 1 trained on (query of round r adds to it)."""
    return labeled_in_round(wildcards, int(wildcards.round) - 1)


def given_labels(wildcards):
    """Labels a person gave for round r's training (none with a simulated oracle)."""
    if wildcards.dataset not in HUMAN:
        return []
    return round_file(wildcards, int(wildcards.round), "labels.npz")


def previous_round(wildcards, name):
    return round_file(wildcards, int(wildcards.round) - 1, name)


def train_params(wildcards):
    """What a round's train job depends on. Strategy parameters (alpha, N_cand) are left
    out: they change only the queries, whose params carry them, so a change reruns a
    method's queries and the rounds after them, not its round 0."""
    entry = config["datasets"][wildcards.dataset]
    method = dataset_method(
        config, wildcards.dataset, wildcards.method, METHODS
    ).as_dict()
    method.pop("params")
    setup = {
        "train": train_setup(config, wildcards.dataset),
        "method": method,
        "ratio_of": entry["al"].get("ratio_of", "train"),
    }
    # the encoder the run reads (a cold start, or selecting on the embedding): its
    # records name it
    encoder = encoder_read(
        config,
        wildcards.dataset,
        wildcards.method,
        seed=int(wildcards.seed),
        specs=METHODS,
    )
    if encoder is not None:
        setup["encoder"] = encoder
    return setup


def queried_after(wildcards):
    """Whether a query reads round r's scores: not in a run's last round (a human
    oracle's rounds go on as long as labels come)."""
    if wildcards.dataset in HUMAN:
        return True
    rounds = runs(wildcards.dataset).get((wildcards.method, int(wildcards.seed)), 0)
    return int(wildcards.round) + 1 < rounds


def query_batch(wildcards):
    """Groups the query of round r adds: `al.batch`, or its entry r - 1 when it is a
    per-round list. A human oracle's rounds past the list (they go on as long as
    labels come) take its last entry."""
    return batch_of(
        config["datasets"][wildcards.dataset]["al"],
        int(wildcards.round),
        f"datasets.{wildcards.dataset}.al.batch",
        past_end=wildcards.dataset in HUMAN,
    )


def query_group(wildcards):
    """Query of round r + 1 runs in one submission with round r's train and score."""
    r = int(wildcards.round) - 1
    return f"round_{wildcards.dataset}_{wildcards.method}_{wildcards.seed}_{r}"


def selects_on_embedding(dataset):
    """Whether a supervised run of the dataset selects on the embedding."""
    names = {m for m, _seed in runs(dataset)}
    return any(
        get_feature_space(METHODS[m].features).needs_encoder
        for m in names
        if m in METHODS
    )


def selection_embeddings(wildcards):
    """The train job's embeddings, when its method selects on them."""
    if not get_feature_space(METHODS[wildcards.method].features).needs_encoder:
        return {}
    # (made by the encoder rule, workflow/rules/embedding.smk): the run seed's own
    entry = config["datasets"][wildcards.dataset]
    eseed = encoder_of(entry, int(wildcards.seed))
    return {"embeddings": encoder_file(wildcards.dataset, eseed, "embeddings.npz")}


def initial_folder(wildcards):
    """Where the method's round-0 set lies (spl_al.layout.initial_folder): initial/ for
    the dataset's own `al.initial_strategy`, initial_{S}/ for a method whose round 0 S
    chooses (a cold-start arm)."""
    start = round0_start(config, wildcards.dataset, wildcards.method, METHODS)
    return f"{RESULTS}/{wildcards.dataset}/{layout.initial_folder(start)}"

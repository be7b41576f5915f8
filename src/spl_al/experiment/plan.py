"""Methods, sweeps and runs of an experiment config (no torch, no data: cheap to import).

A *method* is a named entry: an acquisition strategy, its parameters, and whether
training uses the synthetic variants (the paper's "Syn"). One name is one curve or
one table row. Sensitivity sweeps generate further entries from a base method with
one parameter changed, e.g. ``duis_ncand40``, ``duis_alpha0.25``, ``duis_m2``.

A dataset's ``al`` entry sets the labeled counts: ``initial`` groups at round 0, and
``batch`` more per query, one integer for every query or a list with one per query
(``batch[r]`` is the query that makes round r + 1): ``labeled_at`` and ``batch_of``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from spl_al.cold_start import (
    COLD_START,
    RANDOM,
    START_INFIX,
    initial_strategy,
    is_cold_start,
    start_name,
)
from spl_al.data.sources import check_entry, is_synthesised
from spl_al.experiment.encoders import check_encoders, encoder_of
from spl_al.frameworks import (
    DEFAULT,
    EMBEDDING,
    MODEL_FEATURES,
    framework_names,
    get_feature_space,
    get_framework,
)
from spl_al.report.display import FULL_METHOD
from spl_al.report.table_kinds import TABLE_KINDS, TableContext
from spl_al.scenes.objects import CATEGORIES
from spl_al.strategies import get as get_strategy
from spl_al.strategies import names as strategy_names
from spl_al.strategies.duis import n_cand_error

SWEEP_PARAMETERS = {"n_cand": "ncand", "alpha": "alpha", "n_variants": "m"}

MATCHED_PREFIX = "syn_"

FEATURE_NEEDS = frozenset({"features", "group_features", "labeled_features"})
"""The strategy needs another feature space (``features``, ``spl_al.frameworks``) may
serve: those of features alone."""


def framework_experiments(entry: dict, kind=DEFAULT) -> dict:
    """A dataset entry's experiments (as configured) in framework ``kind`` (a
    ``spl_al.frameworks`` kind or its name)."""
    return get_framework(kind).experiments(entry)


@dataclass(frozen=True)
class MethodSpec:
    """One method: ``strategy`` with ``params``; ``use_variants`` trains on all M + 1
    images of a labeled group; ``n_variants`` (None = the dataset's M) is how many
    variants the method sees, for training and for scoring; ``features``: what a
    feature-only strategy selects on in the supervised framework, a feature space of
    ``spl_al.frameworks`` (the trained model's, or the self-supervised embedding);
    ``initial``: how the method's round 0 is chosen (``spl_al.cold_start``), None for
    the dataset's ``al.initial_strategy`` (the cold-start experiment's arms set it)."""

    name: str
    strategy: str
    params: dict = field(default_factory=dict, hash=False)
    use_variants: bool = False
    n_variants: int | None = None
    features: str = MODEL_FEATURES.name
    initial: str | None = None

    def variants_seen(self, n_variants: int) -> int:
        """M, the variants per group the method sees: its own ``n_variants`` (the M
        sweep), else the dataset's ``n_variants``."""
        return n_variants if self.n_variants is None else int(self.n_variants)

    def train_variants(self, n_variants: int) -> int:
        """Variants per labeled group the method trains on: M with ``use_variants``,
        else 0 (observed images only). ``n_variants``: the dataset's."""
        return self.variants_seen(n_variants) if self.use_variants else 0

    def as_dict(self) -> dict:
        """The method as a JSON-ready dict (``features`` and ``initial`` only when not
        their defaults: a job's recorded settings stay those of a method without them)."""
        out = {
            "strategy": self.strategy,
            "params": dict(self.params),
            "use_variants": self.use_variants,
            "n_variants": self.n_variants,
        }
        if self.features != MODEL_FEATURES.name:
            out["features"] = self.features
        if self.initial is not None:
            out["initial"] = self.initial
        return out


def _format_value(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def sweep_name(base: str, parameter: str, value) -> str:
    """Generated method name of a sweep point, e.g. ``duis_ncand40``."""
    return f"{base}_{SWEEP_PARAMETERS[parameter]}{_format_value(value)}"


def matched_name(method: str) -> str:
    """Name of the matched twin of an observed-only method: ``syn_X`` of ``X``."""
    return f"{MATCHED_PREFIX}{method}"


def entry_strategy(entry: dict) -> tuple[str, dict]:
    """A ``methods`` entry's registered strategy and parameters: ``{strategy: NAME}``
    as it stands, ``{skactiveml: CLASS}`` as the adapter ``skactiveml`` with
    ``cls=CLASS`` (``spl_al.strategies.skactiveml_adapter``)."""
    params = dict(entry.get("params") or {})
    if entry.get("skactiveml") is not None:
        return "skactiveml", {"cls": entry["skactiveml"], **params}
    return entry["strategy"], params


def check_strategies(config: dict, specs: dict | None = None) -> None:
    """Every method's strategy exists (built in or from an installed package's entry
    point), and every method a dataset runs builds with its parameters and the
    dataset's ``method_params``: else a one-sentence ValueError naming the method and
    why (e.g. a scikit-activeml class that needs a classifier, or scikit-activeml not
    installed). A method no experiment runs is not built, so the optional extras of
    the default config's unused methods need not be installed."""
    specs = specs if specs is not None else method_specs(config)
    known = strategy_names()
    for name, spec in specs.items():
        if spec.strategy not in known:
            raise ValueError(
                f"config key 'methods.{name}': unknown strategy {spec.strategy!r}; expected "
                f"one of {known}, or an installed package's entry point in group "
                "'spl_al.strategies'."
            )
    checked = set()
    for dataset in config["datasets"]:
        frameworks: dict[str, set] = {}
        for fw in framework_names():
            for n, _seed in dataset_runs(config, dataset, fw):
                frameworks.setdefault(n, set()).add(fw)
        for name in frameworks:
            if name not in specs:
                continue  # check_plan names it
            spec = dataset_method(config, dataset, name, specs)
            key = (spec.strategy, repr(sorted(spec.params.items())), spec.features)
            try:
                strategy = get_strategy(spec.strategy, **spec.params)
            except ValueError as err:
                raise ValueError(f"config key 'methods.{name}': {err}") from None
            missing = [p for p in strategy.required if getattr(strategy, p, None) is None]
            if missing:
                raise ValueError(
                    f"config key 'methods.{name}.params': {spec.strategy} needs "
                    f"{', '.join(missing)}, which it does not guess (probcover: the task's "
                    "class count, as in params: {n_classes: 11})."
                )
            task = config["datasets"][dataset].get("task")
            supervised = frameworks[name] - {EMBEDDING.name}
            if "head" in strategy.needs and task != "classification" and supervised:
                # the embedding framework's dense probe gives it a head on pooled features
                raise ValueError(
                    f"config key 'methods.{name}': {spec.strategy} reads a classifier's last "
                    f"layer, but {dataset} is a {task} dataset; run it on a classification "
                    "dataset or in its embedding framework."
                )
            if key in checked:
                continue
            checked.add(key)
            scored = set(strategy.needs) - FEATURE_NEEDS
            if spec.features != MODEL_FEATURES.name and scored:
                raise ValueError(
                    f"config key 'methods.{name}.features': {spec.features} replaces a "
                    f"strategy's features only, but {spec.strategy} also needs "
                    f"{sorted(scored)} of the trained model; use features: "
                    f"{MODEL_FEATURES.name}."
                )


def method_specs(config: dict) -> dict[str, MethodSpec]:
    """All methods of a config: the named entries, the generated sweep entries and the
    matched twins of budget experiments with ``matched: true``.

    A sweep value equal to the base method's own value maps to the base method
    itself, so the default point is not run twice. A matched twin ``syn_X`` is X's
    strategy and parameters trained on the variants like DUIS; a ``syn_X`` entry
    under ``methods`` is used as it stands.
    """
    specs = {}
    for name, entry in config["methods"].items():
        strategy, params = entry_strategy(entry)
        specs[name] = MethodSpec(
            name=name,
            strategy=strategy,
            params=params,
            use_variants=bool(entry.get("use_variants", False)),
            n_variants=entry.get("n_variants"),
            features=get_feature_space(entry.get("features", MODEL_FEATURES.name)).name,
            initial=entry.get("initial"),
        )
    for name, point in sweep_points(config).items():
        if name in specs:
            continue
        base = specs[point["base"]]
        params = dict(base.params)
        n_variants = base.n_variants
        if point["parameter"] == "n_variants":
            n_variants = point["value"]
        else:
            params[point["parameter"]] = point["value"]
        specs[name] = MethodSpec(
            name, base.strategy, params, base.use_variants, n_variants, base.features
        )
    budgets = [
        framework_experiments(entry, fw).get("budget") or {}
        for entry in config["datasets"].values()
        for fw in framework_names()
    ]
    for budget in budgets:
        if not budget.get("matched"):
            continue
        for name in budget["methods"]:
            spec = specs.get(name)
            twin = matched_name(name)
            if spec is None or spec.use_variants or twin in specs:
                continue
            specs[twin] = MethodSpec(
                twin, spec.strategy, dict(spec.params), True, spec.n_variants, spec.features
            )
    for entry in config["datasets"].values():
        for fw in framework_names():
            block = framework_experiments(entry, fw).get("cold_start") or {}
            for base in block.get("methods", []):
                for start in block.get("starts", []):
                    name = start_name(base, start)
                    if base in specs and name not in specs:
                        specs[name] = replace(specs[base], name=name, initial=start)
    return specs


def budget_families(
    config: dict, dataset: str, specs=None, framework=DEFAULT
) -> dict[str, list[str]]:
    """The budget experiment's methods grouped by how they train, names in run order:
    how its tables and curves group their rows (a claim's comparators are declared in
    ``spl_al.report.claim_registry``, not taken from these groups).

    ``paper``: the methods trained on observed images only (as the paper trains its
    baselines), and DUIS. ``matched``: every method trained on the variants, DUIS
    included (the matched twins ``syn_X`` of ``matched: true`` and any variant-trained
    method named in ``methods``): a comparison in it varies the acquisition alone.
    Empty lists without a budget experiment.
    """
    specs = specs if specs is not None else method_specs(config)
    budget = framework_experiments(config["datasets"][dataset], framework).get("budget")
    if not budget:
        return {"paper": [], "matched": []}
    named = [m for m in budget["methods"] if m in specs]
    observed = [m for m in named if not specs[m].use_variants]
    twins = [matched_name(m) for m in observed] if budget.get("matched") else []
    variant = [m for m in named if specs[m].use_variants]
    matched = list(dict.fromkeys([*twins, *variant]))
    paper = [*observed, *([FULL_METHOD] if FULL_METHOD in named else [])]
    return {"paper": paper, "matched": matched}


def experiments_of(config: dict, dataset: str, specs=None, framework=DEFAULT) -> dict:
    """A dataset's experiments in ``framework`` as run: the budget experiment's
    ``methods`` hold the matched twins too (observed-only methods first, then the
    variant-trained ones, DUIS last), ``families`` names both families
    (``budget_families``) and ``selection`` says how each method selects and trains:
    {method: {"strategy": ..., "features": ..., "use_variants": ...}} (the claims find
    their declared families' members in it, ``spl_al.report.claim_registry``, never by
    a method's name)."""
    experiments = framework_experiments(config["datasets"][dataset], framework)
    if "budget" not in experiments:
        return experiments
    specs = specs if specs is not None else method_specs(config)
    families = budget_families(config, dataset, specs, framework)
    methods = [m for m in families["paper"] if m != FULL_METHOD]
    methods += [m for m in families["matched"] if m != FULL_METHOD]
    methods += [m for m in experiments["budget"]["methods"] if m not in methods]
    if FULL_METHOD in methods:
        methods = [m for m in methods if m != FULL_METHOD] + [FULL_METHOD]
    selection = {
        m: {
            "strategy": specs[m].strategy,
            "features": specs[m].features,
            "use_variants": bool(specs[m].use_variants),
        }
        for m in methods
        if m in specs
    }
    experiments["budget"] = {
        **experiments["budget"],
        "methods": methods,
        "families": families,
        "selection": selection,
    }
    return experiments


def dataset_method(config: dict, dataset: str, name: str, specs=None) -> MethodSpec:
    """The method ``name`` as run on ``dataset``: the dataset's ``method_params`` (e.g.
    the paper's N_cand = 500 on its synthetic set) update the method's parameters. A
    cold-start arm without its own entry takes its base method's; a sweep point takes
    its base's but for the parameter it varies (one parameter varied, the others the
    dataset's)."""
    specs = specs if specs is not None else method_specs(config)
    spec = specs[name]
    own = config["datasets"][dataset].get("method_params") or {}
    override = own.get(name)
    if override is None and spec.initial is not None and START_INFIX in name:
        override = own.get(name.rsplit(START_INFIX, 1)[0])  # a cold-start arm: its base's
    point = sweep_points(config).get(name) if override is None else None
    if point is not None:
        override = {k: v for k, v in (own.get(point["base"]) or {}).items()}
        override.pop(point["parameter"], None)
    if not override:
        return spec
    return replace(spec, params={**spec.params, **override})


def _base_value(config: dict, base: str, parameter: str):
    entry = config["methods"][base]
    if parameter == "n_variants":
        return entry.get("n_variants")
    return entry.get("params", {}).get(parameter)


def sweep_points(config: dict) -> dict[str, dict]:
    """Generated sweep methods: name -> {base, parameter, value}."""
    sweeps = config.get("sweeps") or {}
    if not sweeps:
        return {}
    base = sweeps["base"]
    if base not in config["methods"]:
        raise ValueError(f"config key 'sweeps.base': {base!r} is not a method in 'methods'.")
    points = {}
    for parameter in SWEEP_PARAMETERS:
        for value in sweeps.get(parameter, []):
            points[sweep_name(base, parameter, value)] = {
                "base": base,
                "parameter": parameter,
                "value": value,
            }
    return points


def sweep_table_spec(config: dict, dataset_m: int) -> dict[str, dict]:
    """parameter -> {value: method name}, the default point mapped to the base method."""
    sweeps = config.get("sweeps") or {}
    base = sweeps.get("base")
    table = {}
    for parameter in SWEEP_PARAMETERS:
        values = sweeps.get(parameter, [])
        if not values:
            continue
        default = _base_value(config, base, parameter)
        if parameter == "n_variants" and default is None:
            default = dataset_m
        table[parameter] = {
            v: (base if v == default else sweep_name(base, parameter, v)) for v in values
        }
    return table


def dataset_runs(config: dict, dataset: str, framework=DEFAULT) -> dict[tuple[str, int], int]:
    """(method, seed) -> number of rounds (trainings) the dataset's experiments in
    ``framework`` need."""
    entry = config["datasets"][dataset]
    exps = experiments_of(config, dataset, framework=framework)
    m = entry.get("variants", {}).get("n", 4)
    ctx = TableContext(exps, sweep_table_spec(config, m))
    runs: dict[tuple[str, int], int] = {}
    for name, kind in TABLE_KINDS.items():
        if name not in exps:
            continue
        for methods, seeds, rounds in kind.runs(exps[name], ctx):
            for method in methods:
                for seed in seeds:
                    runs[(method, seed)] = max(runs.get((method, seed), 0), int(rounds))
    return runs


# ---------------------------------------------------------------- labeled counts


def batch_of(al: dict, round_: int, where: str = "al.batch", past_end: bool = False) -> int:
    """Groups the query that makes round ``round_`` (>= 1) adds: ``al["batch"]``, or its
    entry ``round_ - 1`` when it is a list. ``past_end``: a query past the list's end
    (a human oracle's rounds go on as long as labels come) takes its last entry
    instead of being refused. ``where`` names the key in the error."""
    batch = al["batch"]
    if int(round_) < 1:
        raise ValueError(f"round {round_!r} is made by no query (round 0 is the initial set).")
    if not isinstance(batch, list | tuple):
        return int(batch)
    if int(round_) > len(batch):
        if past_end and batch:
            return int(batch[-1])
        raise ValueError(
            f"config key {where!r} lists {len(batch)} per-round batches, so no query makes "
            f"round {round_}; give one batch per query (rounds - 1 of them)."
        )
    return int(batch[int(round_) - 1])


def labeled_at(al: dict, round_: int) -> int:
    """Groups labeled in round ``round_``: ``initial`` plus every batch up to it."""
    return int(al["initial"]) + sum(batch_of(al, r) for r in range(1, int(round_) + 1))


def train_pool_size(entry: dict) -> int | None:
    """Groups in the training split of a dataset entry when its config fixes them (a
    synthetic set, or a folder's synthetic stand-in), else None (a folder, captures,
    an unlabeled folder: knowable only by reading the data). Mirrors
    ``spl_al.data.procedural.stratified_split``: round(test_fraction * n_c) of each
    class go to test."""
    if not is_synthesised(entry):
        return None
    syn = entry.get("synthesis") or {}
    test_fraction = float(syn.get("test_fraction", 0.3))
    if entry.get("task") == "classification":
        n_per_class = int(syn.get("n_per_class", 100))
        n_classes = len(syn.get("classes") or CATEGORIES)
        return n_classes * (n_per_class - round(test_fraction * n_per_class))
    n = int(syn.get("n_samples", 300))  # one group: the street scans split as one class
    return n - round(test_fraction * n)


def _check_batches(dataset: str, entry: dict, rounds: int) -> None:
    """A per-round batch list needs one batch per query of the longest run."""
    batch = entry["al"]["batch"]
    if not isinstance(batch, list | tuple) or rounds < 1:
        return
    if len(batch) != rounds - 1:
        raise ValueError(
            f"config key 'datasets.{dataset}.al.batch' lists {len(batch)} per-round batches "
            f"but the dataset's experiments make {rounds - 1} queries ({rounds} rounds); "
            f"give {rounds - 1} batches or set the rounds to {len(batch) + 1}."
        )


def _check_candidate_pools(config: dict, dataset: str, runs: dict, specs: dict) -> None:
    """N_cand at most half the unlabeled pool at every query, where the config fixes
    the pool's size."""
    entry = config["datasets"][dataset]
    n_train = train_pool_size(entry)
    if n_train is None:
        return
    rounds_of: dict[str, int] = {}
    for (method, _seed), rounds in runs.items():
        rounds_of[method] = max(rounds_of.get(method, 0), rounds)
    points = sweep_points(config)
    for method, rounds in sorted(rounds_of.items()):
        spec = dataset_method(config, dataset, method, specs)
        n_cand = getattr(get_strategy(spec.strategy, **spec.params), "n_cand", None)
        if n_cand is None:
            continue
        swept = points.get(method, {}).get("parameter") == "n_cand"
        overridden = "n_cand" in ((entry.get("method_params") or {}).get(method) or {})
        key = "the 'sweeps.n_cand' values" if swept and not overridden else None
        for r in range(1, rounds):
            n_unlabeled = n_train - labeled_at(entry["al"], r - 1)
            message = n_cand_error(
                n_cand, n_unlabeled, round_=r, dataset=dataset, method=method, key=key
            )
            if message:
                raise ValueError(message)


def _check_framework_keys(dataset: str, entry: dict) -> None:
    """An experiment's optional ``framework`` key names the framework of where it sits."""
    for name in framework_names():
        kind = get_framework(name)
        for table, experiment in kind.experiments(entry).items():
            given = (experiment or {}).get("framework", name)
            if given != name:
                move = (
                    f"move the experiment under '{get_framework(given).key}' or "
                    if given in framework_names()
                    else ""
                )
                raise ValueError(
                    f"config key 'datasets.{dataset}.{kind.key}.{table}.framework': "
                    f"{given!r} but experiments under '{kind.key}' run the {name} "
                    f"framework; {move}drop the key."
                )


def start_of(config: dict, dataset: str, method: str, specs=None) -> str:
    """How ``method``'s round 0 is chosen on ``dataset``: its own ``initial``, else the
    dataset's ``al.initial_strategy`` (``spl_al.cold_start``)."""
    specs = specs if specs is not None else method_specs(config)
    al = config["datasets"][dataset]["al"]
    return specs[method].initial or initial_strategy(al, f"datasets.{dataset}.al")


def round0_start(config: dict, dataset: str, method: str, specs=None) -> str | None:
    """The start whose own round-0 sets ``method``'s round 0 reads
    (``layout.initial_folder``): None for the dataset's ``al.initial_strategy``, shared
    by every method at a seed; a cold start S for a cold-start arm ``X_from_S``."""
    specs = specs if specs is not None else method_specs(config)
    start = specs[method].initial
    al = config["datasets"][dataset]["al"]
    return None if start is None or start == initial_strategy(al) else start


def _check_initial(config: dict, dataset: str, specs: dict) -> None:
    """Round 0's strategy of every run can be followed: a cold start needs a
    classification dataset with an ``embedding`` block (its encoder), a cold-start
    experiment a simulated oracle and random round 0 to compare with, and ``al.initial``
    at most the training pool (where the config fixes it)."""
    entry = config["datasets"][dataset]
    key = f"datasets.{dataset}.al"
    own = initial_strategy(entry["al"], key)
    starts = {own: f"{key}.initial_strategy"}
    for fw in framework_names():
        block = framework_experiments(entry, fw).get("cold_start")
        if not block:
            continue
        where = f"datasets.{dataset}.{get_framework(fw).key}.cold_start"
        bad = [s for s in block["starts"] if not is_cold_start(s)]
        if bad:
            raise ValueError(
                f"config key '{where}.starts': {bad[0]!r} chooses no first batch on the "
                f"embedding; expected some of {', '.join(COLD_START)}."
            )
        if entry.get("oracle") == "human":
            raise ValueError(
                f"config key '{where}': a human oracle labels one first batch per run, so "
                "it cannot compare several; drop the experiment or use a simulated oracle."
            )
        if own != RANDOM:
            raise ValueError(
                f"config key '{where}' compares first batches with a random one, but "
                f"'{key}.initial_strategy' is {own!r}; set it to random."
            )
        starts.update({s: f"{where}.starts" for s in block["starts"]})
    for start, where in starts.items():
        if not is_cold_start(start):
            continue
        if entry.get("task") != "classification":
            raise ValueError(
                f"config key '{where}': {start} chooses round 0 for a classification "
                f"dataset, but {dataset} is a {entry.get('task')} dataset; use random."
            )
        if not EMBEDDING.enabled(entry):
            raise ValueError(
                f"config key '{where}': {start} chooses round 0 on the dataset's "
                f"self-supervised embedding, but {dataset} has no '{EMBEDDING.block}' block; add "
                "one (e.g. embedding: {encoder: {steps: 300}}) to train its encoder, or "
                "use random."
            )
    n_train = train_pool_size(entry)
    if n_train is not None and int(entry["al"]["initial"]) > n_train:
        raise ValueError(
            f"config key '{key}.initial' asks for {entry['al']['initial']} labeled groups at "
            f"round 0, but the training pool holds {n_train}; lower it to at most {n_train}."
        )


def check_plan(config: dict) -> None:
    """Every method's strategy exists and takes its parameters; every method a
    dataset's experiments name must exist; rounds must be >= 1; a per-round batch list
    has one batch per query; N_cand is at most half the unlabeled pool at every query
    (where the config fixes the pool's size)."""
    specs = method_specs(config)
    check_strategies(config, specs)
    for dataset, entry in config["datasets"].items():
        check_entry(dataset, entry)
        _check_framework_keys(dataset, entry)
        _check_initial(config, dataset, specs)
        runs = {}
        for framework in framework_names():
            for key, rounds in dataset_runs(config, dataset, framework).items():
                runs[key] = max(runs.get(key, 0), rounds)
        for (method, _seed), rounds in runs.items():
            if method not in specs:
                raise ValueError(
                    f"config key 'datasets.{dataset}.experiments': method {method!r} is not "
                    f"defined in 'methods' (known: {', '.join(sorted(specs))})."
                )
            if rounds < 1:
                raise ValueError(
                    f"config key 'datasets.{dataset}.experiments': rounds must be >= 1."
                )
        _check_batches(dataset, entry, max(runs.values(), default=0))
        _check_candidate_pools(config, dataset, runs, specs)
        embedding_seeds = [s for _m, s in dataset_runs(config, dataset, EMBEDDING)]
        ssl_runs = [
            (m, s)
            for m, s in dataset_runs(config, dataset)
            if m in specs and reads_encoder(config, dataset, m, specs)
        ]
        ssl_seeds = [s for _m, s in ssl_runs]
        check_encoders(dataset, entry, [*embedding_seeds, *ssl_seeds], embedding_seeds)
        _check_independent_seeds(dataset, entry, ssl_runs)


def reads_encoder(config: dict, dataset: str, method: str, specs=None) -> bool:
    """Whether a supervised run of ``method`` reads the dataset's self-supervised
    encoder: it selects on the embedding, or its round 0 is chosen on it (a cold start)."""
    specs = specs if specs is not None else method_specs(config)
    return get_feature_space(specs[method].features).needs_encoder or is_cold_start(
        start_of(config, dataset, method, specs)
    )


def encoder_read(config: dict, dataset: str, method: str, *, seed: int, specs=None) -> int | None:
    """The seed of the encoder a supervised run (``method``, ``seed``) reads, which its
    records name (``encoder``), or None for a run that reads none."""
    if not reads_encoder(config, dataset, method, specs):
        return None
    return encoder_of(config["datasets"][dataset], int(seed))


def _check_independent_seeds(dataset: str, entry: dict, ssl_runs) -> None:
    """The supervised framework counts its seeds as independent draws, so two seeds of
    one method must not read the same encoder (a rerun draws the encoder again: seeds
    sharing one are one draw of it); a ValueError naming ``block`` else."""
    seen: dict[tuple[str, int], int] = {}
    for method, seed in sorted(ssl_runs):
        key = (method, encoder_of(entry, seed))
        if key in seen:
            block = f"datasets.{dataset}.embedding.encoder.block"
            raise ValueError(
                f"config key '{block}' makes supervised seeds {seen[key]} and {seed} of "
                f"{method!r} read the same encoder (seed {key[1]}), but the supervised "
                "framework counts seeds as independent draws; set block: 1 with one "
                "encoder seed per run seed, or run the method in the embedding framework, "
                "whose statistics count encoders."
            )
        seen[key] = seed

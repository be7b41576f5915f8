"""Methods, sweeps and runs of an experiment config (no torch, no data: cheap to import).

A *method* is a named entry: an acquisition strategy, its parameters, and whether
training uses the synthetic variants (the paper's "Syn"). One name is one curve or
one table row. Sensitivity sweeps generate further entries from a base method with
one parameter changed, e.g. ``duis_ncand40``, ``duis_alpha0.25``, ``duis_m2``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

SWEEP_PARAMETERS = {"n_cand": "ncand", "alpha": "alpha", "n_variants": "m"}

FULL_METHOD = "duis"
"""The method the experiments are about: the one both families of a budget table hold."""

MATCHED_PREFIX = "syn_"


@dataclass(frozen=True)
class MethodSpec:
    """One method: ``strategy`` with ``params``; ``use_variants`` trains on all M + 1
    images of a labeled group; ``n_variants`` (None = the dataset's M) is how many
    variants the method sees, for training and for scoring."""

    name: str
    strategy: str
    params: dict = field(default_factory=dict, hash=False)
    use_variants: bool = False
    n_variants: int | None = None

    def as_dict(self) -> dict:
        """The method as a JSON-ready dict."""
        return {
            "strategy": self.strategy,
            "params": dict(self.params),
            "use_variants": self.use_variants,
            "n_variants": self.n_variants,
        }


def _format_value(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def sweep_name(base: str, parameter: str, value) -> str:
    """Generated method name of a sweep point, e.g. ``duis_ncand40``."""
    return f"{base}_{SWEEP_PARAMETERS[parameter]}{_format_value(value)}"


def matched_name(method: str) -> str:
    """Name of the matched twin of an observed-only method: ``syn_X`` of ``X``."""
    return f"{MATCHED_PREFIX}{method}"


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
        specs[name] = MethodSpec(
            name=name,
            strategy=entry["strategy"],
            params=dict(entry.get("params", {})),
            use_variants=bool(entry.get("use_variants", False)),
            n_variants=entry.get("n_variants"),
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
        specs[name] = MethodSpec(name, base.strategy, params, base.use_variants, n_variants)
    for entry in config["datasets"].values():
        budget = (entry.get("experiments") or {}).get("budget") or {}
        if not budget.get("matched"):
            continue
        for name in budget["methods"]:
            spec = specs.get(name)
            twin = matched_name(name)
            if spec is None or spec.use_variants or twin in specs:
                continue
            specs[twin] = MethodSpec(twin, spec.strategy, dict(spec.params), True, spec.n_variants)
    return specs


def budget_families(config: dict, dataset: str, specs=None) -> dict[str, list[str]]:
    """The two families of a dataset's budget experiment, method names in run order.

    ``paper``: the methods trained on observed images only, and DUIS (as the paper
    compares: DUIS also trains on its variants). ``matched``: every method trained on
    the variants, DUIS included (the matched twins ``syn_X`` of ``matched: true`` and
    any variant-trained method named in ``methods``): a comparison in it varies the
    acquisition alone. Empty lists without a budget experiment.
    """
    specs = specs if specs is not None else method_specs(config)
    budget = (config["datasets"][dataset].get("experiments") or {}).get("budget")
    if not budget:
        return {"paper": [], "matched": []}
    named = [m for m in budget["methods"] if m in specs]
    observed = [m for m in named if not specs[m].use_variants]
    twins = [matched_name(m) for m in observed] if budget.get("matched") else []
    variant = [m for m in named if specs[m].use_variants]
    matched = list(dict.fromkeys([*twins, *variant]))
    paper = [*observed, *([FULL_METHOD] if FULL_METHOD in named else [])]
    return {"paper": paper, "matched": matched}


def experiments_of(config: dict, dataset: str, specs=None) -> dict:
    """A dataset's ``experiments`` as run: the budget experiment's ``methods`` hold the
    matched twins too (observed-only methods first, then the variant-trained ones,
    DUIS last) and ``families`` names both families (``budget_families``)."""
    experiments = dict(config["datasets"][dataset].get("experiments") or {})
    if "budget" not in experiments:
        return experiments
    families = budget_families(config, dataset, specs)
    methods = [m for m in families["paper"] if m != FULL_METHOD]
    methods += [m for m in families["matched"] if m != FULL_METHOD]
    methods += [m for m in experiments["budget"]["methods"] if m not in methods]
    if FULL_METHOD in methods:
        methods = [m for m in methods if m != FULL_METHOD] + [FULL_METHOD]
    experiments["budget"] = {**experiments["budget"], "methods": methods, "families": families}
    return experiments


def dataset_method(config: dict, dataset: str, name: str, specs=None) -> MethodSpec:
    """The method ``name`` as run on ``dataset``: the dataset's ``method_params`` (e.g.
    the paper's N_cand = 500 on its synthetic set) update the method's parameters."""
    specs = specs if specs is not None else method_specs(config)
    spec = specs[name]
    override = (config["datasets"][dataset].get("method_params") or {}).get(name)
    if not override:
        return spec
    return MethodSpec(
        spec.name, spec.strategy, {**spec.params, **override}, spec.use_variants, spec.n_variants
    )


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


def dataset_runs(config: dict, dataset: str) -> dict[tuple[str, int], int]:
    """(method, seed) -> number of rounds (trainings) the dataset's experiments need."""
    entry = config["datasets"][dataset]
    exps = experiments_of(config, dataset)
    runs: dict[tuple[str, int], int] = {}

    def need(methods, seeds, rounds):
        for m in methods:
            for s in seeds:
                runs[(m, s)] = max(runs.get((m, s), 0), int(rounds))

    budget = exps.get("budget")
    if budget:
        need(budget["methods"], budget["seeds"], budget["rounds"])
    ablation = exps.get("ablation")
    if ablation:
        need(ablation["methods"], ablation["seeds"], ablation["round"] + 1)
    sens = exps.get("sensitivity")
    if sens:
        m = entry.get("variants", {}).get("n", 4)
        for parameter, values in sweep_table_spec(config, m).items():
            rounds = sens["rounds"][parameter]
            need(values.values(), sens["seeds"], rounds + 1)
    return runs


def check_plan(config: dict) -> None:
    """Every method a dataset's experiments name must exist; rounds must be >= 1."""
    specs = method_specs(config)
    for dataset, entry in config["datasets"].items():
        if entry.get("source") == "unlabeled" and entry.get("oracle") != "human":
            raise ValueError(
                f"config key 'datasets.{dataset}.oracle': an unlabeled folder has no labels "
                "to simulate the oracle with; set oracle: human."
            )
        for (method, _seed), rounds in dataset_runs(config, dataset).items():
            if method not in specs:
                raise ValueError(
                    f"config key 'datasets.{dataset}.experiments': method {method!r} is not "
                    f"defined in 'methods' (known: {', '.join(sorted(specs))})."
                )
            if rounds < 1:
                raise ValueError(
                    f"config key 'datasets.{dataset}.experiments': rounds must be >= 1."
                )

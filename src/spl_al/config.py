"""The workflow configuration: validation with one-line errors, removed keys, and the
folders that come from the environment.

Snakemake builds the configuration: ``config/config.yaml`` (the Snakefile's
``configfile:``) is the base, then every ``--configfile`` and ``--config`` is merged
on top of it, nested mappings key by key (lists and values are replaced whole).
A config that sets ``only_datasets`` runs exactly the datasets it lists
(``select_datasets``), whatever datasets config/config.yaml holds.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

# Environment variables naming folders that cannot ship with the repository.
REAL_CAPTURES_ENV = "SPL_AL_REAL_CAPTURES"  # real photon captures (the ugv45m frames)
SSPI_WEIGHTS_ENV = "SPL_AL_SSPI_WEIGHTS"  # SSPI checkpoints


def drop_removed(config: dict) -> dict:
    """Delete every key whose value is null, at any depth, in place; return ``config``.

    A merge can only add or change keys, so an override file removes one by setting
    it to null: ``datasets: {synth_cls: null}`` drops that dataset, ``methods:
    {syn_badge: null}`` that method. (Keys whose null meant "unset" read the same.)
    """
    for key in [k for k, v in config.items() if v is None]:
        del config[key]
    for value in config.values():
        if isinstance(value, dict):
            drop_removed(value)
    return config


NO_PATH = "dataset source is 'folder' but no 'path' is given; set 'path' or 'standin: true'."


def is_standin(entry: dict) -> bool:
    """Whether a dataset entry is a synthetic stand-in for real data: ``source: folder``
    without a ``path``, with ``standin: true`` (``spl_al.data.sources.folder`` then
    synthesises it from ``synthesis``; without ``standin`` such an entry is refused)."""
    return (
        entry.get("source") == "folder"
        and not entry.get("path")
        and bool(entry.get("standin", False))
    )


ONLY_DATASETS = "only_datasets"


def _leaves(entry: dict, prefix: str = "") -> dict:
    """``{dotted key: value}`` of every value below ``entry`` that is not a mapping."""
    out = {}
    for key, value in entry.items():
        if isinstance(value, dict) and value:
            out.update(_leaves(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def select_datasets(config: dict, user: dict) -> dict[str, dict]:
    """Keep only the datasets ``only_datasets`` lists, in place; check every dataset.

    ``config`` is the merged configuration (null keys removed), ``user`` what the
    override files and ``--config`` gave alone, before config/config.yaml was merged
    under them. Without ``only_datasets`` every dataset is kept, as merged. A dataset
    an override sets to null leaves the list. When only config/config.yaml sets it (the
    default run's datasets), a dataset an override defines must be on it (an override
    that adds a dataset names what it runs). Returns, for each kept dataset of an
    override's ``only_datasets`` whose entry took keys the overrides did not give (it
    reuses a name of config/config.yaml), ``{dotted key: value}`` of those keys.
    Raises ValueError naming the key: ``only_datasets`` empty, not a list of names or
    naming no dataset; an override's dataset left out; no dataset left; a dataset
    without ``source``.
    """
    datasets = config.get("datasets")
    if not isinstance(datasets, dict) or not datasets:
        raise ValueError(
            "config key 'datasets' holds no dataset; expected at least one "
            "(a dataset set to null is removed)."
        )
    own = drop_removed(_copy(user)).get("datasets") or {}  # what the overrides define
    only = config.get(ONLY_DATASETS)
    if isinstance(only, list):
        # an override's null removes a dataset from the list too
        removed = {n for n, v in (user.get("datasets") or {}).items() if v is None}
        only = config[ONLY_DATASETS] = [n for n in only if n not in removed]
    if only is not None:
        if not isinstance(only, list) or not all(isinstance(n, str) for n in only):
            raise ValueError(
                f"config key {ONLY_DATASETS!r} is {only!r}; expected a list of dataset names."
            )
        if not only:
            raise ValueError(
                f"config key {ONLY_DATASETS!r} is empty; expected the names of the "
                "datasets to run, at least one."
            )
        for name in only:
            if name not in datasets:
                raise ValueError(
                    f"config key {ONLY_DATASETS!r} names {name!r}, which is not a dataset "
                    f"under 'datasets'; expected one of {', '.join(sorted(datasets))}."
                )
        if ONLY_DATASETS not in user:
            # config/config.yaml's own list: a dataset the overrides define must be on it
            for name in own:
                if name not in only:
                    raise ValueError(
                        f"config key 'datasets.{name}' defines a dataset that "
                        f"{ONLY_DATASETS} ({', '.join(only)}, config/config.yaml's) "
                        f"leaves out; expected {ONLY_DATASETS}: [...] in the same file, "
                        f"listing {name!r} and every other dataset to run."
                    )
        for name in [n for n in datasets if n not in only]:
            del datasets[name]
    for name, entry in datasets.items():
        if not isinstance(entry, dict) or "source" not in entry:
            raise ValueError(
                f"config key 'datasets.{name}.source' is missing; expected a dataset "
                "source (`source` in docs/configuration.md; a new dataset gives task, "
                "source, variants, al, train and experiments itself)."
            )
    if only is None or ONLY_DATASETS not in user:
        return {}
    inherited = {}
    for name in only:
        given = _leaves(own.get(name) or {})
        extra = {k: v for k, v in _leaves(datasets[name]).items() if k not in given}
        if extra:
            inherited[name] = extra
    return inherited


def _copy(value):
    import copy

    return copy.deepcopy(value) if isinstance(value, dict) else {}


def schema_values(node: dict) -> str:
    """What values a leaf of the config schema takes, in words ("integer >= 1, or list
    of integer >= 1"): the key reference's values column and the errors of
    ``check_config``."""
    if "enum" in node:
        return "one of " + ", ".join(flow_value(v) for v in node["enum"])
    if "oneOf" in node or "anyOf" in node:
        return ", or ".join(schema_values(alt) for alt in node.get("oneOf") or node["anyOf"])
    types = node.get("type", "")
    types = [types] if isinstance(types, str) else list(types)
    words = [t for t in types if t and t != "null"]
    text = " or ".join(words) if words else "checked where used"
    if node.get("type") == "array" or "array" in types:
        items = node.get("items", {})
        if isinstance(items, dict) and items.get("type"):
            inner = schema_values(items)
            text = f"list of {inner}"
            if "minItems" in node and node.get("minItems") == node.get("maxItems"):
                text = f"{node['minItems']} x {inner}"
    bounds = []
    if "minimum" in node:
        bounds.append(f">= {flow_value(node['minimum'])}")
    if "exclusiveMinimum" in node:
        bounds.append(f"> {flow_value(node['exclusiveMinimum'])}")
    if "maximum" in node:
        bounds.append(f"<= {flow_value(node['maximum'])}")
    if "exclusiveMaximum" in node:
        bounds.append(f"< {flow_value(node['exclusiveMaximum'])}")
    if bounds:
        text += " " + ", ".join(bounds)
    if "null" in types:
        text += ", or null"
    return text


def flow_value(value: Any) -> str:
    """A config value as it would be written in YAML flow style."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(flow_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {flow_value(v)}" for k, v in value.items()) + "}"
    return str(value)


def check_config(config: dict, schema_path) -> None:
    """Raise ValueError naming the first offending key when ``config`` breaks the schema.

    The message is one sentence: the dotted key path, the value found and what the
    schema expects (for example ``config key 'photon.reconstruct_method': 'sspi' is
    not one of ['pooled', 'lmf']``). A value that fits none of a key's alternatives
    (``oneOf``/``anyOf``, as ``al.batch``: an integer, or a list of them) is reported
    against the alternative of its own type (``config key 'datasets.real_cls.al.batch':
    0 is less than the minimum of 1``), or, when no alternative has its type, with what
    the key takes (``'x' is not integer >= 1, or list of integer >= 1``).
    """
    import jsonschema
    import yaml
    from jsonschema.exceptions import best_match

    # libyaml's loader where PyYAML has it: the pure-Python one takes ~0.4 s of every
    # Snakemake start (dry runs included) on a 2-core AVX2 CPU for this schema
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    schema = yaml.load(Path(schema_path).read_text(), Loader=loader)
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(config), key=lambda e: (len(e.path), list(e.path)))
    if not errors:
        return
    # best_match descends into a oneOf/anyOf failure to the alternative that fits the
    # value best (an integer's minimum, not "0 is not valid under any of the given schemas")
    err = best_match([errors[0]])
    message = err.message
    if err.validator in ("oneOf", "anyOf"):  # no alternative has the value's type
        message = f"{err.instance!r} is not {schema_values(err.schema)}"
    where = ".".join(str(p) for p in err.absolute_path) or "(top level)"
    raise ValueError(f"config key {where!r}: {message} (checked against {schema_path}).")


def real_captures_dir(config: dict, environ=os.environ) -> Path | None:
    """The folder of real .mat captures to picture, or None when none is given.

    ``photon.real_captures`` in the config wins; without it the environment variable
    ``SPL_AL_REAL_CAPTURES`` is used. A folder that is named but missing is an error.
    """
    value = (config.get("photon") or {}).get("real_captures")
    where = "config key 'photon.real_captures'"
    if not value:
        value = environ.get(REAL_CAPTURES_ENV)
        where = f"environment variable {REAL_CAPTURES_ENV}"
    if not value:
        return None
    folder = Path(value)
    if not folder.is_dir():
        raise ValueError(f"{where} names {folder}, which is not a folder.")
    return folder


def dataset_precision(config: dict, dataset: str) -> str:
    """The precision a dataset's models run at as configured ("auto", "fp32", ...): the
    dataset's own ``precision``, else the top-level one, else "auto"."""
    entry = config["datasets"][dataset]
    return entry.get("precision") or config.get("precision") or "auto"


def train_setup(config: dict, dataset: str) -> dict:
    """A dataset's ``train`` entry (``model``, ``fit``, ``warm_start``). Its precision
    is not part of it: it travels in the step's ``Compute`` (``dataset_precision``)."""
    return dict(config["datasets"][dataset]["train"])


STEPS_BY_IMAGES_NOTE = (
    "train.fit.steps_by: images, so training steps scale with images and methods that "
    "train on variants take more optimiser steps than those that do not"
)


def training_notes(config: dict, dataset: str) -> list[str]:
    """Notes a dataset's tables carry about how its methods were trained: one when
    ``train.fit.steps_by`` is "images" (steps are then not equal across methods at a
    budget), one when ``train.warm_start`` fine-tunes each round from the last; none
    under the default policy (epochs count labeled groups, every round fresh weights),
    and none for a dataset that trains no network (no supervised experiment: its
    embedding framework fits a linear probe)."""
    if not config["datasets"][dataset].get("experiments"):
        return []
    train = config["datasets"][dataset].get("train", {})
    fit = train.get("fit") or {}
    notes = [STEPS_BY_IMAGES_NOTE] if fit.get("steps_by") == "images" else []
    warm = train.get("warm_start")
    if warm:
        fields = ", ".join(f"{k}: {v}" for k, v in warm.items())
        notes.append(
            "rounds after round 0 fine-tune the method's previous-round model "
            f"(train.warm_start: {fields}) instead of training fresh weights"
        )
    return notes


SETTINGS_RECORDED = "# Its jobs recorded the settings they read (Snakemake's params).\n"
"""The line of a run's config.yaml that says its jobs recorded their settings: a results
folder without it was made by an older spl-al (``spl_al.experiment.provenance``)."""


def write_config(config: dict, path) -> Path:
    """Write the effective configuration of a run as YAML (atomically, keys sorted)."""
    # yaml on demand (importing this module does not load it)
    import yaml

    from spl_al.atomic import atomic_write_text

    text = (
        "# The configuration this run used (config/config.yaml + overrides).\n" + SETTINGS_RECORDED
    )
    return atomic_write_text(path, text + yaml.safe_dump(config, sort_keys=True))

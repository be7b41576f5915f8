"""Per-round metrics records of active-learning runs: validation and the records frame.

One record is what one round of one run (dataset x method x seed) writes, a JSON object:

    {"dataset": "synth_cls", "method": "duis", "seed": 1, "round": 3,
     "n_labeled": 200, "n_pool": 770, "n_total": 1100, "ratio": 0.1818,
     "metric": "accuracy", "value": 0.873,
     "per_level": {"high": 0.9, "medium": 0.88, "low": 0.84},
     "synthetic_standin": false, "train_seconds": 12.3,
     "train_steps": 300, "images_seen": 9600}

``ratio`` is the labeling ratio n_labeled / n_total; ``value`` and the per-level values
are test metrics in [0, 1]; ``per_level`` may be missing levels or be empty.
``train_steps`` is the number of optimiser steps of the round's training and
``images_seen`` the images those steps drew (steps x batch size); under the default
policy (``TrainConfig.steps_by`` "groups") ``train_steps`` is the same for every method
at a (dataset, seed, round), variants or not. The records frame has one row per record
with ``per_level`` flattened into the columns ``level_high``, ``level_medium``,
``level_low`` (NaN where a level is missing; so are ``train_seconds``, ``train_steps``
and ``images_seen`` where a record has none).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping
from numbers import Integral, Real
from pathlib import Path

import pandas as pd

from spl_al.data.dataset import LEVELS
from spl_al.frameworks import DEFAULT, framework_names

"""MSPPP levels of the test split, in display order."""

LEVEL_COLUMNS = tuple(f"level_{level}" for level in LEVELS)

FRAME_COLUMNS = (
    "dataset",
    "method",
    "seed",
    "round",
    "n_labeled",
    "n_pool",
    "n_total",
    "ratio",
    "metric",
    "value",
    *LEVEL_COLUMNS,
    "synthetic_standin",
    "train_seconds",
    "train_steps",
    "images_seen",
    "precision",
    "framework",
    "encoder",
    "encoder_health",
    "source",
)


# An embedding-framework run's encoder (its record's ``encoder_health``;
# ``spl_al.training.contrastive.encoder_health``; a collapsed one never reaches a run).
ENCODER_HEALTH = ("healthy", "doubtful")

# What a round's model may have been trained at (its record's ``precision``).
TRAINED_AT = ("fp32", "bf16", "fp16")

# A record's ratio may be rounded when written; beyond this it contradicts n_labeled / n_total.
_RATIO_TOLERANCE = 1e-3


def _is_int(x) -> bool:
    return isinstance(x, Integral) and not isinstance(x, bool)


def _is_real(x) -> bool:
    return isinstance(x, Real) and not isinstance(x, bool) and math.isfinite(float(x))


def _unit_interval(x) -> bool:
    return _is_real(x) and 0.0 <= float(x) <= 1.0


def _check_optional(record: Mapping, bad) -> None:
    """Raise ``bad(key, expected)`` for an optional key of a record that is present but
    wrong: n_pool, train_seconds, train_steps, images_seen, precision."""
    n_pool = record.get("n_pool")
    if n_pool is not None and not (_is_int(n_pool) and n_pool >= 0):
        raise bad("n_pool", "an integer >= 0")
    train_seconds = record.get("train_seconds")
    if train_seconds is not None and not (_is_real(train_seconds) and train_seconds >= 0):
        raise bad("train_seconds", "a number of seconds >= 0")
    for key in ("train_steps", "images_seen"):
        count = record.get(key)
        if count is not None and not (_is_int(count) and count >= 1):
            raise bad(key, "an integer >= 1")
    if record.get("precision", TRAINED_AT[0]) not in TRAINED_AT:
        raise bad("precision", f"one of {list(TRAINED_AT)}")
    # How a round's model learned (absent: the default, supervised): spl_al.frameworks.
    if record.get("framework", DEFAULT.name) not in framework_names():
        raise bad("framework", f"one of {list(framework_names())}")
    encoder = record.get("encoder")
    if encoder is not None and not (_is_int(encoder) and encoder >= 0):
        raise bad("encoder", "an encoder seed, an integer >= 0")
    if record.get("encoder_health", ENCODER_HEALTH[0]) not in ENCODER_HEALTH:
        raise bad("encoder_health", f"one of {list(ENCODER_HEALTH)}")


def round_record(
    which: tuple[str, str, int, int],
    *,
    n_labeled: int,
    n_pool: int,
    n_total: int,
    metric: str,
    value: float,
    per_level,
    synthetic_standin: bool,
    **extra,
) -> dict:
    """The metrics record of one round, the one both frameworks write and
    ``load_records`` reads (``validate_record``).

    ``which``: (dataset, method, seed, round); ``n_total``: the ratio's denominator;
    ``per_level``: level -> the metric on that MSPPP level's test images, those without
    a known level ("unknown": folder data without conditions, counted in ``value``) or
    without a value left out; ``extra``: what the framework adds after the shared keys
    (training images and steps, timing, precision, encoder, details)."""
    dataset, method, seed, round_ = which
    return {
        "dataset": dataset,
        "method": method,
        "seed": int(seed),
        "round": int(round_),
        "n_labeled": int(n_labeled),
        "n_pool": int(n_pool),
        "n_total": int(n_total),
        "ratio": n_labeled / n_total,
        "metric": metric,
        "value": float(value),
        "per_level": {
            level: float(v) for level, v in per_level.items() if v is not None and level in LEVELS
        },
        "synthetic_standin": synthetic_standin,
        **extra,
    }


def validate_record(record, where: str = "record") -> dict:
    """Check one metrics record against the contract and return its frame row.

    ``where`` names the record in error messages (a file path, or ``records[3]``).
    Raises ValueError with one sentence naming ``where`` and the missing or bad key.
    Required: dataset, method, metric (non-empty strings), seed, round, n_labeled,
    n_total (integers), value (in [0, 1]), synthetic_standin (bool). Optional, checked
    when present: n_pool, ratio (must equal n_labeled / n_total), per_level, train_seconds,
    train_steps and images_seen (integers >= 1), precision (one of ``TRAINED_AT``; "" in
    the frame when absent).
    """
    if not isinstance(record, Mapping):
        raise ValueError(f"{where}: expected a JSON object, got {type(record).__name__}.")

    def bad(key: str, expected: str):
        if key not in record:
            return ValueError(f"{where}: missing key {key!r} ({expected}).")
        return ValueError(f"{where}: key {key!r} must be {expected}, got {record[key]!r}.")

    for key in ("dataset", "method", "metric"):
        if not (isinstance(record.get(key), str) and record[key].strip()):
            raise bad(key, "a non-empty string")
    for key in ("seed", "round", "n_labeled"):
        if not (_is_int(record.get(key)) and record[key] >= 0):
            raise bad(key, "an integer >= 0")
    if not (_is_int(record.get("n_total")) and record["n_total"] > 0):
        raise bad("n_total", "an integer > 0")
    if record["n_labeled"] > record["n_total"]:
        raise bad("n_labeled", f"at most n_total = {record['n_total']}")
    if not _unit_interval(record.get("value")):
        raise bad("value", "a number in [0, 1]")
    if not isinstance(record.get("synthetic_standin"), bool):
        raise bad("synthetic_standin", "true or false")

    ratio = record["n_labeled"] / record["n_total"]
    if "ratio" in record and not (
        _is_real(record["ratio"]) and abs(float(record["ratio"]) - ratio) <= _RATIO_TOLERANCE
    ):
        raise bad("ratio", f"n_labeled / n_total = {ratio:.4f}")
    _check_optional(record, bad)
    n_pool, train_seconds = record.get("n_pool"), record.get("train_seconds")
    counts = {key: record.get(key) for key in ("train_steps", "images_seen")}

    per_level = record.get("per_level") or {}
    if not isinstance(per_level, Mapping):
        raise bad("per_level", "an object mapping MSPPP level to a metric")
    _check_per_level(per_level, where)

    return {
        "dataset": record["dataset"],
        "method": record["method"],
        "seed": int(record["seed"]),
        "round": int(record["round"]),
        "n_labeled": int(record["n_labeled"]),
        "n_pool": int(n_pool) if n_pool is not None else -1,
        "n_total": int(record["n_total"]),
        # Recomputed so that every seed of a round gets exactly the same ratio.
        "ratio": ratio,
        "metric": record["metric"],
        "value": float(record["value"]),
        **{
            col: float(per_level[level]) if level in per_level else math.nan
            for level, col in zip(LEVELS, LEVEL_COLUMNS, strict=True)
        },
        "synthetic_standin": record["synthetic_standin"],
        "train_seconds": float(train_seconds) if train_seconds is not None else math.nan,
        **{key: float(v) if v is not None else math.nan for key, v in counts.items()},
        "precision": record.get("precision") or "",
        "framework": record.get("framework") or DEFAULT.name,
        # the encoder seed the run read (embedding framework), -1: none
        "encoder": int(encoder) if (encoder := record.get("encoder")) is not None else -1,
        "encoder_health": record.get("encoder_health") or "",
        "source": where,
    }


def _check_per_level(per_level: Mapping, where: str) -> None:
    """A ValueError naming ``where`` unless every key is an MSPPP level and every value
    a metric in [0, 1]."""
    for level, level_value in per_level.items():
        if level not in LEVELS:
            raise ValueError(
                f"{where}: key 'per_level' has level {level!r}; expected one of {list(LEVELS)}."
            )
        if not _unit_interval(level_value):
            raise ValueError(
                f"{where}: key 'per_level' value for {level!r} must be a number in [0, 1], "
                f"got {level_value!r}."
            )


def _frame(rows: list[dict]) -> pd.DataFrame:
    frame = pd.DataFrame(rows, columns=list(FRAME_COLUMNS))
    key = ["dataset", "method", "seed", "round"]
    dup = frame.duplicated(key, keep=False)
    if dup.any():
        first = frame[dup].sort_values(key).iloc[:2]
        d, m, s, r = first.iloc[0][key]
        raise ValueError(
            f"duplicate records for dataset={d!r}, method={m!r}, seed={s}, round={r}: "
            f"{first['source'].iloc[0]} and {first['source'].iloc[1]}."
        )
    for dataset, metrics in frame.groupby("dataset")["metric"].unique().items():
        if len(metrics) > 1:
            raise ValueError(f"dataset {dataset!r} mixes metrics {sorted(metrics)}; expected one.")
    _check_one_precision(frame)
    _check_one_framework(frame)
    return frame.sort_values(key, ignore_index=True)


def _check_one_value(frame: pd.DataFrame, column: str, what: str, remedy: str) -> None:
    """A ValueError unless each dataset's rounds share one known value of ``column``,
    naming a record of each value found (``what``: the rounds' difference in words)."""
    known = frame[frame[column] != ""]
    for dataset, part in known.groupby("dataset"):
        if part[column].nunique() > 1:
            first = part.drop_duplicates(column).sort_values(column)
            found = ", ".join(
                f"{v} ({s})" for v, s in zip(first[column], first["source"], strict=True)
            )
            raise ValueError(f"dataset {dataset!r} mixes rounds {what}, {found}; {remedy}")


def _check_one_precision(frame: pd.DataFrame) -> None:
    """A ValueError unless each dataset's rounds were trained at one precision: a bf16
    and an fp32 run of the same config reach different verdicts (docs/benchmarks.md,
    precision and verdicts), so one table never mixes them."""
    _check_one_value(
        frame,
        "precision",
        "trained at different precisions",
        "rerun them at one precision (the config's `precision:`, e.g. with --forcerun "
        "train_initial train) so that its tables compare like with like.",
    )


def _check_one_framework(frame: pd.DataFrame) -> None:
    """A ValueError unless each dataset's rounds come from one framework."""
    _check_one_value(
        frame, "framework", "of different frameworks", "a table reads one framework's records."
    )


def framework_of(df: pd.DataFrame) -> str:
    """The one framework of the frame's rounds."""
    return str(df["framework"].iloc[0]) if len(df) else DEFAULT.name


def trained_at(df: pd.DataFrame) -> str:
    """The one precision the frame's rounds were trained at ("" when not recorded)."""
    known = sorted(set(df["precision"]) - {""})
    return known[0] if len(known) == 1 else ""


def records_frame(records: Iterable[Mapping]) -> pd.DataFrame:
    """Validate in-memory records and return the records frame (one row per record).

    Columns: ``FRAME_COLUMNS``; sorted by dataset, method, seed, round. ``source`` is
    ``records[i]``. A (dataset, method, seed, round) given twice is a ValueError.
    """
    rows = [validate_record(r, where=f"records[{i}]") for i, r in enumerate(records)]
    if not rows:
        raise ValueError("records is empty; expected at least one metrics record.")
    return _frame(rows)


def load_records(paths) -> pd.DataFrame:
    """Read metrics JSON files (one record each, or a list of them) into the records frame.

    ``paths``: one path or an iterable of paths. A file that is not JSON, or whose
    record breaks the contract, raises a ValueError naming the file and the key.
    """
    if isinstance(paths, str | os.PathLike):
        paths = [paths]
    rows = []
    for path in map(Path, paths):
        try:
            record = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ValueError(f"{path}: not a readable JSON metrics record ({exc}).") from None
        if isinstance(record, list):  # a runs file: every round of a method's runs
            rows += [validate_record(r, where=f"{path}[{i}]") for i, r in enumerate(record)]
        else:
            rows.append(validate_record(record, where=str(path)))
    if not rows:
        raise ValueError("paths is empty; expected at least one metrics JSON file.")
    return _frame(rows)


def one_dataset(df: pd.DataFrame, dataset: str | None = None) -> pd.DataFrame:
    """The records of one dataset: ``dataset`` if given, else the frame's only dataset."""
    names = sorted(df["dataset"].unique())
    if dataset is None:
        if len(names) != 1:
            raise ValueError(f"df holds datasets {names}; pass dataset= to pick one.")
        return df
    if dataset not in names:
        raise ValueError(f"dataset {dataset!r} is not in df; it holds {names}.")
    return df[df["dataset"] == dataset]


def round_for_budget(df: pd.DataFrame, budget: int) -> int:
    """The round whose number of labeled samples is closest to ``budget`` (earlier on ties).

    Uses the median n_labeled of each round over all methods and seeds of ``df``.
    """
    if not (_is_int(budget) and budget >= 0):
        raise ValueError(f"budget must be an integer number of labeled samples, got {budget!r}.")
    per_round = df.groupby("round")["n_labeled"].median()
    if per_round.empty:
        raise ValueError("df has no records; cannot pick a round for a budget.")
    return int((per_round - budget).abs().idxmin())

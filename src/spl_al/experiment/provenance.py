"""What changed since the last run into a results folder, for the plan a run prints.

Snakemake reruns a job when a setting it reads changed (each rule's ``params``), and
every job after it; this module only tells the user why, before anything runs: the
config keys whose values differ from those recorded in the folder's ``config.yaml``
(written by the last run that completed it), and, for a folder made by an older spl-al
whose jobs recorded no settings, the one sentence saying that everything reruns once
and which flag keeps the folder as it is.
"""

from __future__ import annotations

from pathlib import Path

from spl_al.config import SETTINGS_RECORDED

OLDER_RESULTS = (
    "{results}/ was made by an older spl-al whose jobs did not record the settings they "
    "read, so each of its jobs reruns once to record them, unless the run is given "
    "`--rerun-triggers mtime input`, which keeps its results as they are (and then reruns "
    "nothing for a changed setting)."
)
"""The sentence for a results folder whose jobs' records hold no settings."""

RUN_FACTS = ("precision_used",)
"""Keys a run adds to its config.yaml (what it found on the machine), not settings."""

SHOWN = 12
"""Changed keys listed one by one; the rest are counted."""


def _short(value) -> str:
    text = repr(value) if isinstance(value, str) else str(value)
    return text if len(text) <= 40 else text[:37] + "..."


def config_changes(recorded: dict, current: dict, prefix: str = "") -> list[str]:
    """The differences between two configs, one line each, keys sorted: ``KEY OLD ->
    NEW`` for a changed value (lists compared whole), ``KEY added`` / ``KEY removed``
    for a key on one side only (a whole entry, e.g. a dataset, as one line)."""
    lines = []
    for key in sorted(set(recorded) | set(current), key=str):
        name = f"{prefix}{key}"
        if key not in recorded:
            lines.append(f"{name} added")
        elif key not in current:
            lines.append(f"{name} removed")
        elif isinstance(recorded[key], dict) and isinstance(current[key], dict):
            lines += config_changes(recorded[key], current[key], f"{name}.")
        elif recorded[key] != current[key]:
            lines.append(f"{name} {_short(recorded[key])} -> {_short(current[key])}")
    return lines


def changes_text(recorded_path, current: dict) -> str | None:
    """The plan's lines on what changed since the run that wrote ``recorded_path`` (a
    results folder's ``config.yaml``); None when it does not exist or nothing changed."""
    import yaml

    path = Path(recorded_path)
    if not path.is_file():
        return None
    recorded = yaml.safe_load(path.read_text()) or {}
    for key in RUN_FACTS:
        recorded.pop(key, None)
    lines = config_changes(recorded, current)
    if not lines:
        return None
    shown = [f"  {line}" for line in lines[:SHOWN]]
    if len(lines) > SHOWN:
        shown.append(f"  ... and {len(lines) - SHOWN} more")
    head = f"Changed since the last run into {path.parent}/ (its config.yaml):"
    return "\n".join([head, *shown])


def rerun_line(n_settings: int) -> str:
    """How many of a run's jobs rerun because a setting they read changed (the plan's
    jobs line); empty when none do."""
    if not n_settings:
        return ""
    return f" ({n_settings} because a setting they read changed, the rest after them or new)"


def older_results(recorded_path) -> bool:
    """Whether the results folder whose ``config.yaml`` is ``recorded_path`` was made by
    an older spl-al, whose jobs recorded no settings (no ``SETTINGS_RECORDED`` line)."""
    path = Path(recorded_path)
    return path.is_file() and SETTINGS_RECORDED not in path.read_text()

"""A budget experiment's ``selection`` (what each method runs: strategy, features,
training), as ``spl_al.experiment.plan.experiments_of`` gives it, for comparison frames
made by hand: the methods of the default config (``config/config.yaml``) by key."""

from __future__ import annotations

from pathlib import Path

import yaml

DEFAULT_CONFIG = Path(__file__).resolve().parents[2] / "config" / "config.yaml"


def selection_of(methods) -> dict:
    """{method: {"strategy", "features", "use_variants"}} of ``methods`` as the default
    config defines them (DUIS's sweep points are DUIS)."""
    defined = yaml.safe_load(DEFAULT_CONFIG.read_text())["methods"]
    out = {}
    for method in methods:
        entry = defined.get(method) or defined["duis"]
        out[method] = {
            "strategy": entry["strategy"],
            "features": entry.get("features", "model"),
            "use_variants": bool(entry.get("use_variants", False)),
        }
    return out

"""Acquisition strategies behind one registry and one calling convention.

``get(name, **params)`` builds a strategy; ``names()`` lists them. A strategy has
``needs`` (what ``spl_al.scoring.compute_inputs`` must compute) and
``select(inputs, budget, rng)`` -> training-set indices of the groups to label.

- random; entropy; margin: classic baselines (segmentation: means over valid pixels).
- coreset: k-center greedy on penultimate features (Sener & Savarese 2018).
- badge: k-means++ seeding on last-layer gradient embeddings (Ash et al. 2020).
- duis: the paper's method (params n_cand, alpha, eps); diversity: DUIS with alpha = 0.
- typiclust, probcover, maxherding, skactiveml (any feature-only class): scikit-activeml's
  low-budget strategies through one adapter (``skactiveml_adapter``; the optional extra
  ``spl-al[baselines]``).
- anything another installed package registers under the entry-point group
  ``spl_al.strategies`` (``base.load_entry_points``).

Pure scoring pieces: ``entropy.entropy_score``, ``margin.margin_score``,
``duis.margin_and_inconsistency``, ``duis.uis``, ``coreset.k_center_greedy``,
``badge.kmeans_pp_seeding``, ``kmeans.kmeans``. Importing and running the strategies
needs numpy only (no torch, no scikit-learn); the scikit-activeml ones import it (and
scikit-learn) when built.
"""

from spl_al.strategies import (
    badge,
    coreset,
    diversity,
    duis,
    entropy,
    kmeans,
    margin,
    random_sampling,
    skactiveml_adapter,
)
from spl_al.strategies.base import (
    ENTRY_POINT_GROUP,
    Strategy,
    StrategyContractError,
    check_picks,
    get,
    load_entry_points,
    names,
    register,
)
from spl_al.strategies.inputs import GROUP_NEEDS, NEEDS, StrategyInputs

__all__ = [
    "ENTRY_POINT_GROUP",
    "GROUP_NEEDS",
    "NEEDS",
    "Strategy",
    "StrategyContractError",
    "StrategyInputs",
    "badge",
    "check_picks",
    "coreset",
    "diversity",
    "duis",
    "entropy",
    "get",
    "kmeans",
    "load_entry_points",
    "margin",
    "names",
    "random_sampling",
    "register",
    "skactiveml_adapter",
]

"""Acquisition strategies behind one registry and one calling convention.

``get(name, **params)`` builds a strategy; ``names()`` lists them. A strategy has
``needs`` (what ``spl_al.scoring.compute_inputs`` must compute) and
``select(inputs, budget, rng)`` -> training-set indices of the groups to label.

- random; entropy; margin: classic baselines (segmentation: means over valid pixels).
- coreset: k-center greedy on penultimate features (Sener & Savarese 2018).
- badge: k-means++ seeding on last-layer gradient embeddings (Ash et al. 2020).
- duis: the paper's method (params n_cand, alpha, eps); diversity: DUIS with alpha = 0.
- typiclust, probcover: the low-budget strategies on L2-normalised features, as their
  papers' reference code runs them (``typiclust``, ``probcover``).
- dropquery: dropout-disagreement candidates, then k-means (Gupte et al. 2024), DUIS's
  generic twin; it reads the classifier's last layer (need ``head``).
- maxherding, skactiveml (any feature-only class): scikit-activeml's strategies through
  one adapter (``skactiveml_adapter``; the optional extra ``spl-al[baselines]``).
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
    dropquery,
    duis,
    entropy,
    kmeans,
    margin,
    probcover,
    random_sampling,
    skactiveml_adapter,
    typiclust,
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
    "dropquery",
    "duis",
    "entropy",
    "get",
    "kmeans",
    "load_entry_points",
    "margin",
    "names",
    "probcover",
    "random_sampling",
    "register",
    "skactiveml_adapter",
    "typiclust",
]

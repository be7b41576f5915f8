"""Margin sampling: the groups whose observed image has the smallest top1 - top2 gap."""

from __future__ import annotations

import numpy as np

from spl_al.strategies.base import Strategy, register
from spl_al.strategies.inputs import StrategyInputs
from spl_al.strategies.units import check_probs, top_gap, top_k, unit_mean


def margin_score(probs, valid=None) -> np.ndarray:
    """Mean over valid units of p(top1) - p(top2) (small = uncertain).

    Args:
        probs: (groups, units, classes); valid: optional (groups, units) bool mask.

    Returns:
        (groups,) float64; NaN for a group without valid units.
    """
    return unit_mean(top_gap(check_probs(probs, 3)), valid)


@register
class MarginStrategy(Strategy):
    """The k groups with the smallest ``margin_score`` of the observed image."""

    name = "margin"
    needs = frozenset({"margin"})

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        return top_k(-np.asarray(inputs.margin, dtype=np.float64), k, rng)

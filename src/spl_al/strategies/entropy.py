"""Entropy sampling: the groups whose observed image has the most uncertain prediction."""

from __future__ import annotations

import numpy as np

from spl_al.strategies.base import Strategy, register
from spl_al.strategies.inputs import StrategyInputs
from spl_al.strategies.units import check_probs, top_k, unit_mean


def entropy_score(probs, valid=None) -> np.ndarray:
    """Mean predictive entropy over valid units, H = -sum_c p_c log p_c (nats).

    Args:
        probs: (groups, units, classes) class probabilities (units = 1 per image for
            classification, pixels for segmentation).
        valid: optional (groups, units) bool mask of the units that count.

    Returns:
        (groups,) float64; NaN for a group without valid units.
    """
    p = check_probs(probs, 3)
    h = -np.sum(np.where(p > 0, p * np.log(np.where(p > 0, p, 1.0)), 0.0), axis=-1)
    return unit_mean(h, valid)


@register
class EntropyStrategy(Strategy):
    """Top-k groups by ``entropy_score`` of the observed image."""

    name = "entropy"
    needs = frozenset({"entropy"})

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        return top_k(inputs.entropy, k, rng)

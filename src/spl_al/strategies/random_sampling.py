"""Random sampling: uniform without replacement over the unlabeled pool."""

from __future__ import annotations

import numpy as np

from spl_al.strategies.base import Strategy, register
from spl_al.strategies.inputs import StrategyInputs


@register
class RandomStrategy(Strategy):
    """``k`` groups drawn uniformly without replacement with the run's rng."""

    name = "random"
    needs = frozenset()

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        return rng.choice(inputs.n_unlabeled, size=k, replace=False)

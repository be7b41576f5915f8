"""The strategy interface and the registry every strategy module registers into."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from spl_al.strategies.inputs import StrategyInputs, check_needs

_REGISTRY: dict[str, type[Strategy]] = {}


class Strategy:
    """An acquisition strategy: picks unlabeled groups to send to the oracle.

    Subclasses set ``name`` and ``needs`` (names from ``spl_al.strategies.inputs.NEEDS``)
    and implement ``_select(inputs, k, rng)``, returning ``k`` distinct positions into
    ``inputs.unlabeled_idx``. ``select`` validates and maps them to training-set indices.
    """

    name: ClassVar[str] = ""
    needs: ClassVar[frozenset[str]] = frozenset()

    def select(self, inputs: StrategyInputs, budget: int, rng: np.random.Generator) -> np.ndarray:
        """Indices (into the training set) of up to ``budget`` unlabeled groups to label.

        Returns ``min(budget, n_unlabeled)`` unique indices, all from
        ``inputs.unlabeled_idx``, in the strategy's order of preference. The same
        inputs and the same ``rng`` state give the same answer.
        """
        if isinstance(budget, bool) or not isinstance(budget, int | np.integer) or budget < 0:
            raise ValueError(f"budget must be an integer >= 0, got {budget!r}.")
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}.")
        if not isinstance(inputs, StrategyInputs):
            raise ValueError(f"inputs must be StrategyInputs, got {type(inputs).__name__}.")
        k = min(int(budget), inputs.n_unlabeled)
        if k == 0:  # nothing to pick: an empty pool needs no scores
            return np.zeros(0, dtype=np.int64)
        inputs.require(self.needs)
        pos = np.asarray(self._select(inputs, k, rng), dtype=np.int64)
        if (
            pos.shape != (k,)
            or len(np.unique(pos)) != k
            or pos.min() < 0
            or pos.max() >= inputs.n_unlabeled
        ):
            raise RuntimeError(f"strategy {self.name!r} returned invalid positions {pos!r}.")
        return inputs.unlabeled_idx[pos]

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        raise NotImplementedError

    def params(self) -> dict:
        """The strategy's parameters (for logs and records)."""
        return {}

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({args})"


def register(cls: type[Strategy]) -> type[Strategy]:
    """Class decorator: add a strategy to the registry under ``cls.name``."""
    if not cls.name or cls.name in _REGISTRY:
        raise ValueError(f"strategy name {cls.name!r} is empty or already registered.")
    check_needs(cls.needs)
    _REGISTRY[cls.name] = cls
    return cls


def names() -> list[str]:
    """Names of the registered strategies."""
    return sorted(_REGISTRY)


def get(name: str, **params) -> Strategy:
    """The strategy ``name`` built with ``params`` (e.g. ``get("duis", n_cand=500, alpha=0.5)``)."""
    if name not in _REGISTRY:
        raise ValueError(f"unknown strategy {name!r}; expected one of {names()}.")
    try:
        return _REGISTRY[name](**params)
    except TypeError as exc:
        raise ValueError(f"bad parameters for strategy {name!r}: {exc}.") from None

"""The strategy interface and the registry every strategy module registers into.

Strategies of other installed packages join the registry through the entry-point
group ``spl_al.strategies``: an entry ``NAME = package.module:Class`` (a ``Strategy``
subclass) makes NAME a strategy like a built-in one, e.g. in a package's
``pyproject.toml``::

    [project.entry-points."spl_al.strategies"]
    mine = "my_package.strategy:MyStrategy"

They are looked up when a name is not a built-in (``get``) and by ``names()``.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from types import MappingProxyType
from typing import ClassVar

import numpy as np

from spl_al.strategies.inputs import StrategyInputs, check_needs

ENTRY_POINT_GROUP = "spl_al.strategies"

_REGISTRY: dict[str, type[Strategy]] = {}
_BUILTIN: set[str] = set()
# sys.path at the last entry-point scan: a changed path (a package added) scans again
_SCANNED_FOR: list[tuple[str, ...] | None] = [None]
_FROM_ENTRY_POINTS: set[str] = set()  # names the last scan registered
_SCANNING: list[str] = []  # the entry point being loaded (its @register is not built-in)


class StrategyContractError(ValueError):
    """A strategy's picks broke the contract (a labeled or unknown index, a repeat, or
    the wrong count); the message is one sentence naming the strategy and its picks."""


def _shown(values, limit: int = 12) -> str:
    values = [int(v) for v in np.asarray(values).ravel()]
    more = f" and {len(values) - limit} more" if len(values) > limit else ""
    return f"{values[:limit]}{more}"


def check_picks(name: str, picked, inputs: StrategyInputs, budget: int) -> np.ndarray:
    """``picked`` as int64 training-set indices if they keep the contract: exactly
    ``min(budget, n_unlabeled)`` distinct indices, all of unlabeled groups; else a
    ``StrategyContractError``, one sentence naming the strategy and what it returned."""
    k = min(int(budget), inputs.n_unlabeled)
    arr = np.asarray(picked)
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        raise StrategyContractError(
            f"strategy {name!r} returned {arr.dtype} values {_shown(arr)} instead of "
            "integer indices of unlabeled groups."
        )
    arr = arr.astype(np.int64).ravel()
    values, counts = np.unique(arr, return_counts=True)
    labeled = np.intersect1d(arr, inputs.labeled_idx)
    unknown = np.setdiff1d(arr, np.concatenate([inputs.unlabeled_idx, inputs.labeled_idx]))
    problems = []
    if len(arr) != k:
        problems.append(f"{len(arr)} indices for a batch of {k}")
    if labeled.size:
        problems.append(f"the labeled groups {_shown(labeled)}")
    if (counts > 1).any():
        problems.append(f"the repeated indices {_shown(values[counts > 1])}")
    if unknown.size:
        problems.append(f"the indices {_shown(unknown)} of no unlabeled group")
    if problems:
        raise StrategyContractError(
            f"strategy {name!r} returned {_shown(arr)}: " + ", ".join(problems) + "."
        )
    return arr


class Strategy:
    """An acquisition strategy: picks unlabeled groups to send to the oracle.

    Subclasses set ``name`` and ``needs`` (names from ``spl_al.strategies.inputs.NEEDS``)
    and implement ``_select(inputs, k, rng)``, returning ``k`` distinct positions into
    ``inputs.unlabeled_idx``. ``select`` validates and maps them to training-set indices.
    """

    name: ClassVar[str] = ""
    needs: ClassVar[frozenset[str]] = frozenset()
    # What the last ``select`` decided beyond its picks (a JSON-able dict, empty for
    # most strategies): ProbCover's radius and coverage, TypiClust's clusters, ...
    # Each round's record keeps it.
    decision: Mapping = MappingProxyType({})
    # parameters a selection cannot do without (ProbCover's n_classes): a strategy is
    # built without them (a training step asks only for its needs), a plan is refused
    required: ClassVar[tuple[str, ...]] = ()

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
        self.decision = {}
        if k == 0:  # nothing to pick: an empty pool needs no scores
            return np.zeros(0, dtype=np.int64)
        inputs.require(self.needs)
        pos = np.asarray(self._select(inputs, k, rng)).ravel()
        if (
            not np.issubdtype(pos.dtype, np.integer)
            or pos.shape != (k,)
            or len(np.unique(pos)) != k
            or pos.min() < 0
            or pos.max() >= inputs.n_unlabeled
        ):
            raise StrategyContractError(
                f"strategy {self.name!r} returned the positions {_shown(pos)} for a batch of "
                f"{k}, not {k} distinct positions in 0..{inputs.n_unlabeled - 1} of the "
                "unlabeled groups."
            )
        return inputs.unlabeled_idx[pos.astype(np.int64)]

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
    if not _SCANNING:
        _BUILTIN.add(cls.name)
    return cls


def load_entry_points(force: bool = False) -> list[str]:
    """Register the strategies of the installed packages' ``spl_al.strategies`` entry
    points (again when ``sys.path`` changed or ``force``); their names, sorted.

    An entry point's name is the strategy's name; it must load a ``Strategy``
    subclass whose ``name`` is empty or the same. A broken entry point is a ValueError
    naming it and its distribution."""
    from importlib.metadata import entry_points

    path = tuple(sys.path)
    if _SCANNED_FOR[0] == path and not force:
        return sorted(set(_REGISTRY) - _BUILTIN)
    _SCANNED_FOR[0] = path
    # The registry holds the entry points of this sys.path: a package no longer on it
    # (uninstalled, or a path taken off again) takes its strategies with it.
    for name in _FROM_ENTRY_POINTS:
        _REGISTRY.pop(name, None)
    _FROM_ENTRY_POINTS.clear()
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        where = f"entry point {ep.name!r} ({ep.value}) of group {ENTRY_POINT_GROUP!r}"
        dist = getattr(ep, "dist", None)
        if dist is not None:
            where += f" of {dist.metadata['Name']}"
        if ep.name in _BUILTIN:
            raise ValueError(f"{where} takes the name of the built-in strategy {ep.name!r}.")
        _SCANNING.append(ep.name)
        try:
            cls = ep.load()
        except Exception as exc:
            raise ValueError(f"{where} failed to load: {type(exc).__name__}: {exc}") from None
        finally:
            _SCANNING.pop()
        if not (isinstance(cls, type) and issubclass(cls, Strategy)):
            raise ValueError(f"{where} is {cls!r}, not a spl_al.strategies.Strategy subclass.")
        if cls.name and cls.name != ep.name:
            raise ValueError(f"{where} loads a strategy named {cls.name!r}; name them alike.")
        known = _REGISTRY.get(ep.name)
        if known is not None and known is not cls:
            raise ValueError(f"{where} loads {cls!r}, but {ep.name!r} is already {known!r}.")
        if known is None:
            cls.name = ep.name
            check_needs(cls.needs)
            _REGISTRY[ep.name] = cls
        _FROM_ENTRY_POINTS.add(ep.name)
    return sorted(set(_REGISTRY) - _BUILTIN)


def builtin_names() -> list[str]:
    """Names of the strategies this package defines (no entry points)."""
    return sorted(_BUILTIN)


def names() -> list[str]:
    """Names of the registered strategies, those of installed entry points included."""
    load_entry_points()
    return sorted(_REGISTRY)


def get(name: str, **params) -> Strategy:
    """The strategy ``name`` built with ``params`` (e.g. ``get("duis", n_cand=500, alpha=0.5)``)."""
    if name not in _REGISTRY:
        load_entry_points()
    if name not in _REGISTRY:
        raise ValueError(f"unknown strategy {name!r}; expected one of {names()}.")
    try:
        return _REGISTRY[name](**params)
    except TypeError as exc:
        raise ValueError(f"bad parameters for strategy {name!r}: {exc}.") from None

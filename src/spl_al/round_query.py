"""The query of an active-learning round: the one step both frameworks take to pick the
groups the oracle labels next, whatever model scored them.

A k-means candidate-pool strategy (DUIS, diversity) must draw N_cand from at least
twice as many unlabeled groups (``strategies.duis.check_candidate_pool``); the random
choices come from the query's own stream (``seeding.round_rng(QUERY, seed, r)``, r the
round just trained, so the query that makes round r + 1; the same for every method at a
seed); the picks are held to the strategy contract
whatever the strategy (one from another package may override ``select``): ``batch``
(or every remaining) distinct indices of unlabeled groups.
"""

from __future__ import annotations

import numpy as np

from spl_al.seeding import QUERY, round_rng
from spl_al.strategies import StrategyContractError, StrategyInputs, check_picks
from spl_al.strategies.duis import check_candidate_pool


def query_batch(
    strategy,
    name: str,
    inputs: StrategyInputs,
    batch: int,
    *,
    seed: int,
    round_: int,
    dataset: str | None = None,
    method: str | None = None,
) -> np.ndarray:
    """The ``batch`` groups (indices into the training pool) that ``strategy`` (built
    from registered strategy ``name``) picks from ``inputs`` for round ``round_``, the
    round the query makes; ``seed``, ``dataset`` and ``method`` name the run.

    One sentence naming the run, the round, N_cand and the pool when the candidate pool
    is too large (``CandidatePoolTooLarge``), or the run, the round, the strategy and
    what it returned when the picks break the contract (``StrategyContractError``)."""
    where = {"round_": round_, "dataset": dataset, "method": method, "seed": seed}
    check_candidate_pool(strategy, int(inputs.n_unlabeled), **where)
    rng = round_rng(QUERY, seed, round_ - 1)
    try:
        return check_picks(name, strategy.select(inputs, int(batch), rng), inputs, batch)
    except StrategyContractError as err:
        run = f"{dataset}/{method}" if dataset and method else method or "run"
        raise StrategyContractError(
            f"{run} seed {seed}: the query that makes round {round_} stopped, as {err}"
        ) from None

"""Round 0's labeled set: drawn at random, stratified by class, or chosen without a
label on the dataset's self-supervised embedding (the cold start).

A dataset's ``al.initial_strategy`` says how its round-0 ``al.initial`` groups are
chosen; a method's ``initial`` overrides it for that method (the cold-start
experiment's arms):

- ``random`` (the default, the paper's protocol): uniform without replacement;
- ``stratified`` (also ``al.stratified_initial: true``): as even over classes as the
  counts allow; it reads the oracle's training labels, so a human oracle refuses it;
- ``typiclust``, ``probcover``, ``maxherding``: the strategy of that name, with its
  paper's settings (``spl_al.strategies``), selecting ``al.initial`` groups from an
  empty labeled set on the embeddings of the groups' observed images. This is what
  TypiClust was made for (Hacohen et al., ICML 2022: "typical" samples of a
  self-supervised embedding are the best first batch at tiny budgets); ProbCover
  (Yehuda et al., NeurIPS 2022) and MaxHerding (Bae et al., ECCV 2024) claim the same.
  No label is read: the strategy sees the embeddings alone.

Every choice is a function of (the pool, the size, the run seed) and, for a cold start,
the embedding of the run seed's encoder: the same for every method that starts so,
which keeps comparisons between methods paired. The random stream is
``spl_al.pool.initial_labeled_set``'s.
"""

from __future__ import annotations

import numpy as np

from spl_al.pool import initial_labeled_set
from spl_al.seeding import round0_rng

RANDOM, STRATIFIED = "random", "stratified"
COLD_START = ("typiclust", "probcover", "maxherding")
"""The strategies that choose round 0 on the self-supervised embedding, without a label."""
INITIAL_STRATEGIES = (RANDOM, STRATIFIED, *COLD_START)

START_INFIX = "_from_"
"""Joins a cold-start arm's base method and round-0 strategy: ``duis_from_typiclust``."""


def start_name(base: str, start: str) -> str:
    """Generated name of a cold-start arm: method ``base`` whose round 0 ``start``
    chooses, e.g. ``duis_from_typiclust``."""
    return f"{base}{START_INFIX}{start}"


def split_start_name(name: str) -> tuple[str, str] | None:
    """(base, start) of a cold-start arm's name, or None for any other name."""
    base, sep, start = name.rpartition(START_INFIX)
    return (base, start) if sep and start in COLD_START and base else None


def initial_strategy(al: dict, where: str = "al") -> str:
    """How round 0 is chosen under the ``al`` block: ``initial_strategy``, else
    ``stratified`` for ``stratified_initial: true``, else ``random``. A name outside
    ``INITIAL_STRATEGIES``, or ``stratified_initial: true`` beside another strategy, is
    a ValueError naming the key (``where``: the block's config path)."""
    name = al.get("initial_strategy")
    stratified = bool(al.get("stratified_initial", False))
    if name is None:
        return STRATIFIED if stratified else RANDOM
    if name not in INITIAL_STRATEGIES:
        raise ValueError(
            f"config key '{where}.initial_strategy': unknown strategy {name!r}; expected one "
            f"of {', '.join(INITIAL_STRATEGIES)}."
        )
    if stratified and name != STRATIFIED:
        raise ValueError(
            f"config key '{where}.stratified_initial' asks for a stratified round 0 but "
            f"'{where}.initial_strategy' is {name!r}; keep one of them."
        )
    return name


def is_cold_start(name: str) -> bool:
    """Whether round 0 chosen by ``name`` reads the self-supervised embedding."""
    return name in COLD_START


def first_batch(
    embeddings: np.ndarray, size: int, seed: int, strategy: str, *, n_classes: int | None = None
) -> tuple[np.ndarray, dict]:
    """The ``size`` groups ``strategy`` (one of ``COLD_START``) picks from an empty
    labeled set.

    Args:
        embeddings: (N, d) one embedding per training group (its observed image's).
        size: groups to pick (1 <= size <= N).
        seed: the run seed (the round-0 stream of ``spl_al.pool``).
        strategy: ``typiclust``, ``probcover`` or ``maxherding``, built with its
            paper's defaults.
        n_classes: the task's class count: ProbCover's radius rule clusters the
            embedding into that many groups (no label read).

    Returns:
        (sorted indices into the N groups, what the strategy decided: ProbCover's
        radius and coverage, TypiClust's clusters, MaxHerding's bandwidth).
    """
    # the strategies on demand: the report reads this module's names without them
    from spl_al.strategies import StrategyInputs, check_picks, get

    if strategy not in COLD_START:
        raise ValueError(f"a cold start is one of {', '.join(COLD_START)}, got {strategy!r}.")
    x = np.asarray(embeddings, dtype=np.float32)
    if x.ndim != 2:
        raise ValueError(f"embeddings must be (N, d), got shape {x.shape}.")
    n = len(x)
    if int(size) != size or not 1 <= size <= n:
        raise ValueError(f"size must be an integer in [1, {n}], got {size!r}.")
    # what the strategy declares it cannot select without (ProbCover's class count)
    given = {"n_classes": None if n_classes is None else int(n_classes)}
    needed = get(strategy).required
    missing = [p for p in needed if given.get(p) is None]
    if missing:
        raise ValueError(f"a {strategy} cold start needs {', '.join(missing)}, none given.")
    chooser = get(strategy, **{p: given[p] for p in needed})
    inputs = StrategyInputs(
        unlabeled_idx=np.arange(n, dtype=np.int64),
        labeled_idx=np.zeros(0, dtype=np.int64),
        features=x,
        labeled_features=np.zeros((0, x.shape[1]), dtype=np.float32),
    )
    rng = round0_rng(seed)
    picks = check_picks(strategy, chooser.select(inputs, int(size), rng), inputs, int(size))
    return np.sort(np.asarray(picks, dtype=np.int64)), dict(chooser.decision)


def round0_set(
    strategy: str,
    n_train: int,
    size: int,
    seed: int,
    *,
    labels=None,
    embeddings=None,
    n_classes: int | None = None,
    where: str = "al.initial",
) -> tuple[np.ndarray, dict]:
    """Round 0's labeled set of a run seed, however it is chosen.

    ``labels`` (N,): the oracle's training labels, read for ``stratified`` alone;
    ``embeddings`` (N, d): read for a cold start alone. ``where`` names the size's
    config key in the error when ``size`` exceeds the pool. Returns (sorted training-
    split indices, how they were chosen: ``{"strategy": ...}`` plus a cold start's
    decision).
    """
    if int(size) > int(n_train):
        raise ValueError(
            f"config key '{where}' asks for {int(size)} labeled groups at round 0, but the "
            f"training pool holds {int(n_train)}; lower it to at most {int(n_train)}."
        )
    if strategy in (RANDOM, STRATIFIED):
        stratified = strategy == STRATIFIED
        idx = initial_labeled_set(
            n_train, size, seed, labels=labels if stratified else None, stratified=stratified
        )
        return idx, {"strategy": strategy}
    if embeddings is None:
        raise ValueError(f"a {strategy} round 0 selects on embeddings, and none were given.")
    if len(embeddings) != int(n_train):
        raise ValueError(
            f"the embeddings hold {len(embeddings)} training groups, the pool {int(n_train)}; "
            "train the encoder again for this dataset (remove it and rerun)."
        )
    idx, decision = first_batch(embeddings, size, seed, strategy, n_classes=n_classes)
    return idx, {"strategy": strategy, **({"decision": decision} if decision else {})}

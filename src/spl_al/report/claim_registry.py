"""Every claim spl-al judges, declared before any run: its id, where it comes from, the
experiment it reads, and the comparators it tests.

A claim's comparators are a *family* declared here by what its members run (a
strategy, trained on the variants or not, ``Family``), matched against the budget
experiment's ``selection`` (the run's methods: {method: {"strategy", "features",
"use_variants"}}, ``spl_al.experiment.plan.experiments_of``). They never come from
which methods did best, and a method added to a run joins no paper claim: "as the
paper compares" means DUIS against the paper's five baselines trained on observed
images (``PAPER_BASELINES``), those of them the run has; each added family has an
extension claim of its own, with Holm over its members (``spl_al.report.claims``).

A claim's sentence names every comparator it tested, and says "only" when the run
lacks some of the family's declared members; ``claims.csv``'s ``methods`` column lists
the method keys.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from spl_al.report.decomposition import PARTS
from spl_al.report.display import FULL_METHOD

PAPER, EXTENSION = "paper", "extension"

PAPER_BASELINES = ("random", "entropy", "margin", "coreset", "badge")
"""The strategies the paper compares DUIS with (each trained on observed images only)."""

LOW_BUDGET = ("typiclust", "probcover", "maxherding")
"""The low-budget baselines' strategies (``spl_al.strategies.skactiveml_adapter``)."""


@dataclass(frozen=True)
class Family:
    """DUIS's comparators in a claim: the run's methods whose strategy is one of
    ``strategies`` and that train on the variants (``use_variants``) or not.
    ``words``: how the claim's sentence names the comparison ("as the paper
    compares")."""

    name: str
    strategies: tuple[str, ...]
    use_variants: bool
    words: str

    def members(self, selection: Mapping | None) -> list[str]:
        """The method keys of ``selection`` in this family, in its order (DUIS never)."""
        return [
            method
            for method, how in (selection or {}).items()
            if method != FULL_METHOD
            and how.get("strategy") in self.strategies
            and bool(how.get("use_variants", False)) == self.use_variants
        ]

    def missing(self, selection: Mapping | None) -> list[str]:
        """The declared strategies none of whose methods the run has, in order."""
        present = {selection[m]["strategy"] for m in self.members(selection)}
        return [s for s in self.strategies if s not in present]


PAPER_FAMILY = Family("paper", PAPER_BASELINES, False, "as the paper compares")
MATCHED_FAMILY = Family("matched", PAPER_BASELINES, True, "matched training")
LOW_BUDGET_FAMILY = Family("low_budget", LOW_BUDGET, True, "under matched training")
DROPQUERY_FAMILY = Family("dropquery", ("dropquery",), True, "under matched training")
FAMILIES = (PAPER_FAMILY, MATCHED_FAMILY, LOW_BUDGET_FAMILY, DROPQUERY_FAMILY)


@dataclass(frozen=True)
class ClaimSpec:
    """One declared claim: ``source`` (``PAPER`` or ``EXTENSION``), the ``experiment``
    whose comparisons it reads, and its comparators: a ``family`` of DUIS's
    (``points``: "rounds", "aubc" or "levels"), or a fixed ``pair`` (A, B) of method
    keys, A claimed better; claims of neither kind (sweeps, cold start) name theirs in
    ``spl_al.report.claims``."""

    claim_id: str
    source: str
    experiment: str
    family: Family | None = None
    points: str = ""
    pair: tuple[str, str] | None = None
    what: str = ""


def _versus(claim_id: str, source: str, family: Family, points: str) -> ClaimSpec:
    experiment = "levels" if points == "levels" else "budget"
    return ClaimSpec(claim_id, source, experiment, family=family, points=points)


CLAIMS: tuple[ClaimSpec, ...] = (
    _versus("duis_best_every_budget", PAPER, PAPER_FAMILY, "rounds"),
    _versus("duis_best_aubc", EXTENSION, PAPER_FAMILY, "aubc"),
    _versus("duis_best_every_level", PAPER, PAPER_FAMILY, "levels"),
    _versus("duis_best_every_budget_matched", EXTENSION, MATCHED_FAMILY, "rounds"),
    _versus("duis_best_aubc_matched", EXTENSION, MATCHED_FAMILY, "aubc"),
    _versus("duis_best_every_level_matched", EXTENSION, MATCHED_FAMILY, "levels"),
    _versus("duis_over_low_budget_matched", EXTENSION, LOW_BUDGET_FAMILY, "aubc"),
    _versus("condition_over_dropout_inconsistency", EXTENSION, DROPQUERY_FAMILY, "aubc"),
    *(
        ClaimSpec(
            part,
            PAPER
            if part in ("diversity_over_uncertainty", "inconsistency_over_diversity")
            else EXTENSION,
            "budget",
            pair=(a, b),
            what=what,
        )
        for part, a, b, what in PARTS
    ),
    ClaimSpec(
        "diversity_over_random",
        PAPER,
        "ablation",
        pair=("syn_diversity", "syn_random"),
        what="diversity over random",
    ),
    ClaimSpec("m_gt_1_beats_m_1", PAPER, "sensitivity"),
    ClaimSpec("ncand_grows_to_plateau", PAPER, "sensitivity"),
    ClaimSpec("alpha_half_not_worse", PAPER, "sensitivity"),
    ClaimSpec("typical_first_batch", EXTENSION, "cold_start"),
)
"""Every claim, in the order tables list them. The decomposition's parts (``PARTS``)
are read on the budget's AUBC when the run has all five of their methods, else at the
ablation round; the paper orders diversity over uncertainty and inconsistency over
diversity (its ablation), the other parts are this project's."""

CLAIM_SPECS = {spec.claim_id: spec for spec in CLAIMS}

FIRST_BATCH_CLAIM = CLAIM_SPECS["typical_first_batch"].claim_id
"""Claim id prefix of the cold-start experiment's claims, one per strategy S
(``typical_first_batch_typiclust``, ...)."""


def source_of(claim_id: str) -> str:
    """``PAPER`` or ``EXTENSION`` of a claim id (a cold-start claim by its prefix)."""
    spec = CLAIM_SPECS.get(claim_id)
    if spec is None and claim_id.startswith(f"{FIRST_BATCH_CLAIM}_"):
        spec = CLAIM_SPECS[FIRST_BATCH_CLAIM]
    if spec is None:
        raise ValueError(f"claim {claim_id!r} is not declared in spl_al.report.claim_registry.")
    return spec.source

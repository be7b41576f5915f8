"""Syn+Diversity (the paper's ablation): DUIS's candidate pool ranked by uncertainty alone."""

from __future__ import annotations

from spl_al.strategies.base import register
from spl_al.strategies.duis import MAX_CAND_FRACTION, DUISStrategy


@register
class DiversityStrategy(DUISStrategy):
    """DUIS with alpha = 0: k-means candidate pool, then the smallest margins gamma.

    Args:
        n_cand: N_cand; eps, max_iter, max_cand_fraction: as DUIS (at most half the
            unlabeled pool by default).
    """

    name = "diversity"

    def __init__(
        self,
        n_cand: int = 500,
        eps: float = 1e-8,
        max_iter: int = 100,
        max_cand_fraction: float | None = MAX_CAND_FRACTION,
    ) -> None:
        super().__init__(
            n_cand=n_cand,
            alpha=0.0,
            eps=eps,
            max_iter=max_iter,
            max_cand_fraction=max_cand_fraction,
        )

    def params(self) -> dict:
        """The strategy's parameters, as recorded with its results."""
        return {"n_cand": self.n_cand, "eps": self.eps}

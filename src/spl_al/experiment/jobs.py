"""The small records a round step takes, importable without numpy or torch (the
workflow's scripts build them in the job's own process before handing the step on)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Compute:
    """Where a step's models run: torch ``device`` ("auto", "cpu", "cuda") and the
    number of torch ``threads`` (None: torch's choice). The precision is the fit's."""

    device: str = "auto"
    threads: int | None = None

    def apply(self) -> None:
        """Set torch's thread count (imports torch)."""
        import torch

        if self.threads:
            torch.set_num_threads(int(self.threads))


@dataclass(frozen=True)
class RoundId:
    """Which round: dataset and method names, run seed, round index (0 = initial set)."""

    dataset: str
    method: str
    seed: int
    round: int


@dataclass(frozen=True)
class ModelFiles:
    """What a fit writes: the weights, a JSON record and the scores of the pool."""

    model: str | Path
    record: str | Path
    scores: str | Path | None = None


LOCAL = Compute()
"""Torch's own device choice ("auto") and thread count."""

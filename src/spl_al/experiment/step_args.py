"""The small records a step takes (where its models run, which round, its files, what
its model starts from), importable without numpy or torch: the workflow's scripts
build them in the job's own process before handing the step on."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path


@dataclass(frozen=True)
class Compute:
    """Where and how a step's models run: torch ``device`` ("auto", "cpu", "cuda"),
    the number of torch ``threads`` (None: torch's choice) and the numeric
    ``precision`` of training and every forward pass ("fp32", "bf16", "fp16", or
    "auto": ``spl_al.training.precision``).

    A step resolves it once per model (``resolved``); everything after reads the
    concrete device and precision from it.
    """

    device: str = "auto"
    threads: int | None = None
    precision: str = "fp32"

    def apply(self) -> None:
        """Set torch's thread count (imports torch)."""
        import torch

        if self.threads:
            torch.set_num_threads(int(self.threads))

    def resolved(self, model=None) -> Compute:
        """This Compute with the device torch uses ("cpu", "cuda", ...) and the
        precision ``model`` (an instance or its class) runs at there: what "auto"
        means on this machine (imports torch)."""
        from spl_al.training import resolve_device
        from spl_al.training.precision import resolve_precision

        device = resolve_device(self.device)
        precision = resolve_precision(self.precision, device, model)
        return replace(self, device=str(device), precision=precision)


@dataclass(frozen=True)
class RoundId:
    """Which round: dataset and method names, run seed, round index (0 = initial set)."""

    dataset: str
    method: str
    seed: int
    round: int


@dataclass(frozen=True)
class RoundStart:
    """What a round's model starts from besides its labeled set: round 0's shared fit
    (``initial``: ``train_initial``'s files), the method's previous-round weights to
    fine-tune (``previous_model``), and a person's labels (``labels_path``) instead of
    the dataset's. All None: fresh weights on the dataset's labels."""

    initial: ModelFiles | None = None
    previous_model: str | Path | None = None
    labels_path: str | Path | None = None


@dataclass(frozen=True)
class ModelFiles:
    """What a fit writes: the weights, a JSON record and the scores of the pool."""

    model: str | Path
    record: str | Path
    scores: str | Path | None = None


LOCAL = Compute()
"""Torch's own device choice ("auto") and thread count."""

FRESH = RoundStart()
"""Fresh weights on the dataset's labels (``train_round``'s default start)."""

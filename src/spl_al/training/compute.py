"""Where and how models run: ``Compute`` (importable without numpy or torch).

A workflow step builds one from its job's settings, resolves it once for its model
(``resolved``: what "auto" means on this machine) and passes it down: ``train``,
``predict``, ``evaluate``, ``iter_forward`` and the scoring step take the resolved
Compute and never resolve it again. A call without one runs on the default
``Compute()`` resolved for its model (CUDA when there is one, fp32).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace


@dataclass(frozen=True)
class Compute:
    """Torch ``device`` ("auto", "cpu", "cuda", "cuda:N"), the number of torch
    ``threads`` (None: torch's choice) and the numeric ``precision`` of training and
    every forward pass ("fp32", "bf16", "fp16", or "auto": ``spl_al.training.precision``).
    ``is_resolved``: made by ``resolved``, so device and precision are concrete and
    checked."""

    device: str = "auto"
    threads: int | None = None
    precision: str = "fp32"
    is_resolved: bool = field(default=False, compare=False, repr=False)

    def apply(self) -> None:
        """Set torch's thread count and IEEE fp32 (no TF32 on CUDA: fp32 means fp32 on
        every device, ``spl_al.training.device.ieee_fp32``); a step's first act,
        imports torch."""
        import torch  # only when a step runs: job scripts import this module

        from spl_al.training.device import ieee_fp32  # imports torch, as above

        ieee_fp32()
        if self.threads:
            torch.set_num_threads(int(self.threads))

    def resolved(self, model=None) -> Compute:
        """This Compute with the device torch uses ("cpu", "cuda", ...) and the
        precision ``model`` (an instance or its class) runs at there; an already
        resolved one as it is."""
        if self.is_resolved:
            return self
        # torch only when resolved: job scripts build a Compute before handing it on
        from spl_al.training.device import resolve_device
        from spl_al.training.precision import resolve_precision

        device = resolve_device(self.device)
        precision = resolve_precision(self.precision, device, model)
        return replace(self, device=str(device), precision=precision, is_resolved=True)

    def measuring(self) -> Compute:
        """This Compute, resolved, at ``MEASURE_PRECISION`` (fp32): scores and metrics
        are measured so whatever precision trained the model."""
        from spl_al.training.precision import MEASURE_PRECISION  # torch, as resolved

        return replace(self, precision=MEASURE_PRECISION, is_resolved=False).resolved()

    @property
    def torch_device(self):
        """The resolved device as a ``torch.device``."""
        import torch  # see apply

        if not self.is_resolved:
            raise ValueError("Compute.torch_device needs a resolved Compute (Compute.resolved).")
        return torch.device(self.device)


LOCAL = Compute()
"""The default: CUDA when there is one, else the CPU; torch's threads; fp32."""

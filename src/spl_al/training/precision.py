"""Numeric precision of a model's forward passes: fp32, or mixed precision by autocast.

Mixed precision runs convolutions and matrix products in a 16-bit float while the
weights, the optimiser state and the loss stay fp32 (``torch.autocast``). On a CPU
with native bf16 (AVX512-BF16 or AMX) and on a CUDA GPU, bf16 trains a model of this
project ~1.5-1.7x faster than fp32 at the same accuracy (``python -m spl_al.bench
training``). fp16 has a narrower exponent than bf16 and needs its gradients scaled so
that small ones do not flush to zero (``torch.amp.GradScaler``); it runs on CUDA only.

Names: "fp32" (no autocast), "bf16", "fp16", and "auto" = bf16 where the hardware
computes it natively, else fp32. Results at different precisions differ in their
last digits (and so may a run's tables); each is deterministic on its own.

One edge seen with torch 2.13's CPU kernels (oneDNN): a padded convolution whose
output map is 1x1 gets garbage (uninitialised) bf16 weight gradients at the taps that
see only padding. Those taps never touch the output, so training still works, but the
weights differ from process to process. The models of this project never shrink a map
to 1x1 at their configured image sizes; for very small images, use fp32.
"""

from __future__ import annotations

import contextlib

import torch

PRECISIONS = ("auto", "fp32", "bf16", "fp16")

MEASURE_PRECISION = "fp32"
"""The precision of the forward passes whose numbers decide something, whatever
precision trained the model: the pool's probabilities and features that a strategy
selects from (margins, DUIS's inconsistency between a group's images, the k-means
pool, TypiClust's and ProbCover's neighbourhoods) and the test metrics of every round.
A bf16 number keeps 8 bits of mantissa, so bf16 features and logits are rounded to a
few thousand distinct values, and what a strategy ranks by (near-tied margins, the KL
divergence between a group's images) moves with that rounding. Only training runs at
the configured precision."""
_DTYPES = {"bf16": torch.bfloat16, "fp16": torch.float16}


def native_bf16(device: torch.device) -> bool:
    """Whether ``device`` computes bf16 in hardware: a CUDA GPU that supports it, or a
    CPU with AVX512-BF16 or AMX-BF16 (elsewhere bf16 is emulated and slower than fp32)."""
    if device.type == "cuda":
        return torch.cuda.is_bf16_supported()
    if device.type != "cpu":
        return False
    capability = getattr(torch._C._cpu, "_get_cpu_capability", None)
    if capability is None:  # a torch without the query: assume emulation
        return False
    caps = capability()
    return bool(caps.get("avx512_bf16") or caps.get("amx_bf16"))


def resolve_precision(name: str, device: torch.device, model=None) -> str:
    """The precision ``model`` runs at on ``device``: "fp32", "bf16" or "fp16".

    "auto" is bf16 where ``native_bf16(device)`` and the model gains from it, else
    fp32: a model whose class sets ``auto_bf16 = False`` (PointNet++, whose many small
    layers and neighbour searches trained 0.86x as fast in bf16 on a CPU) stays fp32.
    fp16 is refused off CUDA (CPUs gain nothing from it, and it needs gradient scaling
    that only CUDA supports here); bf16 on a device without native bf16 is taken as
    asked (emulated, slower).
    """
    if name not in PRECISIONS:
        raise ValueError(f"precision must be one of {list(PRECISIONS)}, got {name!r}.")
    if name == "auto":
        gains = getattr(model, "auto_bf16", True) or device.type == "cuda"
        return "bf16" if native_bf16(device) and gains else "fp32"
    if name == "fp16" and device.type != "cuda":
        raise ValueError(
            f"precision 'fp16' needs a CUDA device, got {device.type}; "
            "use 'bf16' or 'auto' on a CPU."
        )
    return name


def autocast(precision: str, device: torch.device) -> contextlib.AbstractContextManager:
    """The autocast context of a resolved ``precision`` on ``device`` (fp32: none)."""
    if precision == "fp32":
        return contextlib.nullcontext()
    return torch.autocast(device.type, dtype=_DTYPES[precision])


class LossScaler:
    """Dynamic loss scaling for fp16 (``torch.amp.GradScaler``); a no-op otherwise.

    ``backward(loss)`` then ``step(optimizer)``: with fp16 the loss is multiplied by the
    scale before backward, the gradients are divided by it before the update, a step
    whose gradients overflow is skipped and the scale lowered.
    """

    def __init__(self, precision: str, device: torch.device) -> None:
        self._scaler = None
        if precision == "fp16":
            from torch.amp import GradScaler

            self._scaler = GradScaler(device.type)

    def backward(self, loss: torch.Tensor) -> None:
        """Backpropagate ``loss`` (times the scale with fp16)."""
        (loss if self._scaler is None else self._scaler.scale(loss)).backward()

    def step(self, optimizer) -> None:
        """Update (unscaled gradients; with fp16 skipped on overflow, scale updated)."""
        if self._scaler is None:
            optimizer.step()
        else:
            self._scaler.step(optimizer)
            self._scaler.update()

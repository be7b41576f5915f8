"""Where torch runs a step (``resolve_device``), deterministically
(``deterministic_algorithms``) and in true fp32 (``ieee_fp32``)."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

import torch

# cuBLAS is only deterministic with a fixed workspace; this must be set before the
# first cuBLAS handle exists, hence at import (a user's own value is kept).
os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")


def resolve_device(name: str | torch.device | None = None) -> torch.device:
    """The torch device for ``name``: None or "auto" picks CUDA when available, else CPU.

    "cpu", "cuda" and "cuda:N" are taken as given; asking for CUDA without it is an error.
    """
    if isinstance(name, torch.device):
        name = str(name)
    if name is None or name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if not isinstance(name, str) or not (name == "cpu" or name.split(":")[0] == "cuda"):
        raise ValueError(f"device must be 'auto', 'cpu', 'cuda' or 'cuda:N', got {name!r}.")
    if name.startswith("cuda") and not torch.cuda.is_available():
        raise ValueError(f"device {name!r} was requested but CUDA is not available here.")
    return torch.device(name)


def _set_deterministic(mode: bool, warn_only: bool) -> None:
    # torch.use_deterministic_algorithms also sets inductor's flag, importing
    # torch._inductor and torch._dynamo: ~1 s of every job's start-up for a compiler
    # never used here. The flag eager kernels read is this one.
    setter = getattr(torch._C, "_set_deterministic_algorithms", None)
    if setter is None:  # a torch without the private setter: the public call
        torch.use_deterministic_algorithms(mode, warn_only=warn_only)
    else:
        setter(mode, warn_only=warn_only)


@contextmanager
def deterministic_algorithms() -> Iterator[None]:
    """Run the block with torch's deterministic kernels (cuDNN too), then restore.

    ``warn_only``: an op without a deterministic kernel warns instead of failing.
    """
    previous = (
        torch.are_deterministic_algorithms_enabled(),
        torch.is_deterministic_algorithms_warn_only_enabled(),
        torch.backends.cudnn.deterministic,
        torch.backends.cudnn.benchmark,
    )
    _set_deterministic(True, warn_only=True)
    torch.backends.cudnn.deterministic = True
    torch.backends.cudnn.benchmark = False
    try:
        yield
    finally:
        _set_deterministic(previous[0], warn_only=previous[1])
        torch.backends.cudnn.deterministic = previous[2]
        torch.backends.cudnn.benchmark = previous[3]


def ieee_fp32() -> None:
    """fp32 matmuls and convolutions in IEEE fp32, never TF32, on every device.

    cuDNN's convolutions default to TF32 on Ampere and later GPUs (10 mantissa bits),
    so an "fp32" run there would be another numeric draw than the same run on a CPU.
    bf16/fp16 autocast regions are unaffected: this governs fp32 operands alone. torch
    2.9 replaced the ``allow_tf32`` flags by ``fp32_precision``; an older torch (a CUDA
    build ``scripts/install.sh`` keeps) gets the flags.
    """
    matmul, cudnn = torch.backends.cuda.matmul, torch.backends.cudnn
    if hasattr(getattr(cudnn, "conv", None), "fp32_precision"):  # torch >= 2.9
        matmul.fp32_precision = "ieee"
        cudnn.conv.fp32_precision = "ieee"
    else:  # older torch: the two flags that API replaced
        matmul.allow_tf32 = False
        cudnn.allow_tf32 = False

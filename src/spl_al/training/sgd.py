"""Stochastic gradient descent with momentum, the update ``torch.optim.SGD`` makes.

Why not ``torch.optim.SGD`` itself: every ``torch.optim`` optimiser wraps its methods in
``torch._disable_dynamo``, whose first call imports ``torch._dynamo`` (and sympy):
1-1.5 s of a training job's start-up on a CPU, paid once per job and ~260 times in a
default run, for a compiler this project never uses. The update below is the same
arithmetic in the same order (``torch.optim.SGD`` with dampening 0), so weights are
equal bit for bit (tests/test_training.py checks it).
"""

from __future__ import annotations

from collections.abc import Iterable

import torch


class SGD:
    """Momentum SGD with L2 weight decay; ``param_groups[0]["lr"]`` sets the rate.

    Per parameter p with gradient g (``torch.optim.SGD``, dampening 0):

        g <- g + weight_decay * p
        b <- g                      (first step)
        b <- momentum * b + g       (later steps)
        g <- g + momentum * b  if nesterov,  else  g <- b
        p <- p - lr * g

    Parameters without a gradient in a step are left alone, and so is their buffer.
    """

    def __init__(
        self,
        params: Iterable[torch.nn.Parameter],
        lr: float,
        momentum: float = 0.0,
        nesterov: bool = False,
        weight_decay: float = 0.0,
    ) -> None:
        if nesterov and momentum <= 0:
            raise ValueError("SGD: nesterov momentum needs momentum > 0.")
        self.params = [p for p in params if p.requires_grad]
        # "params" lets torch.amp.GradScaler unscale the gradients (fp16 training).
        self.param_groups = [{"lr": float(lr), "params": self.params}]
        self.momentum = float(momentum)
        self.nesterov = bool(nesterov)
        self.weight_decay = float(weight_decay)
        self._buffers: list[torch.Tensor | None] = [None] * len(self.params)

    def zero_grad(self, set_to_none: bool = True) -> None:
        """Drop (or zero) every parameter's gradient."""
        for p in self.params:
            if set_to_none:
                p.grad = None
            elif p.grad is not None:
                p.grad.zero_()

    @torch.no_grad()
    def step(self) -> None:
        """One update of every parameter that has a gradient (the rule above)."""
        live = [i for i, p in enumerate(self.params) if p.grad is not None]
        params = [self.params[i] for i in live]
        grads = [p.grad for p in params]
        if not params:
            return
        if self.weight_decay != 0:
            grads = torch._foreach_add(grads, params, alpha=self.weight_decay)
        if self.momentum != 0:
            seen = []  # positions in ``live`` whose buffer existed before this step
            for k, i in enumerate(live):
                if self._buffers[i] is None:
                    self._buffers[i] = grads[k].detach().clone()
                else:
                    seen.append(k)
            if seen:
                old = [self._buffers[live[k]] for k in seen]
                torch._foreach_mul_(old, self.momentum)
                torch._foreach_add_(old, [grads[k] for k in seen])
            bufs = [self._buffers[i] for i in live]
            nesterov = self.nesterov
            grads = torch._foreach_add(grads, bufs, alpha=self.momentum) if nesterov else bufs
        torch._foreach_add_(params, grads, alpha=-self.param_groups[0]["lr"])

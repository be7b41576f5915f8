"""Multinomial logistic regression fitted by L-BFGS: scikit-learn's objective, written
for the dense probe's many small fits.

``fit_multinomial`` minimises scikit-learn's ``LogisticRegression`` objective (solver
``lbfgs``, L2, intercept, sample weights) with scikit-learn's solver settings, so it
reaches the same optimum from the same start (the same coefficients within the
solver's tolerance): for K classes, coefficients W (K, d) and intercepts b (K,),

    f(W, b) = sum_i s_i [log sum_k exp(z_ik) - z_i,y_i] / S + |W|^2 / (2 C S),
    z_i = W x_i + b,  S = sum_i s_i,

with its gradient dF/d[W b] = ((softmax(z) - onehot(y)) * s / S)^T [X 1] + [W / (C S), 0].

Why not scikit-learn's own: a dense round's fit (10,000 pixels x 41 features x 7
classes, ~70 iterations) spent most of its time in the generic loss's per-call
overhead; the vectorised loss and gradient below take about half as long
(docs/benchmarks.md#segmentation-in-the-embedding-framework).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

MAX_ITER = 500
MAX_LINE_SEARCH = 50  # scikit-learn's (scipy's default is 20)


class Problem(NamedTuple):
    """A fit's fixed arrays: [X 1] (n, d + 1) and its transpose, s_i / S at (y_i, i)
    of a (K, n) ``target``, s_i / S (n,) and the L2 strength 1 / (C S)."""

    x1: np.ndarray
    x1t: np.ndarray
    target: np.ndarray
    share: np.ndarray
    l2: float


def loss_gradient(flat, problem: Problem):
    """(f, df) at coefficients ``flat``: (K, d + 1) raveled in Fortran order (the
    classes of one feature contiguous, as scikit-learn lays them out). Class-major
    (K, n) logits: numpy reduces over K = 7 classes ~20x faster down the rows than
    along each pixel's short row."""
    x1, target, share, l2 = problem.x1, problem.target, problem.share, problem.l2
    coef = flat.reshape((len(target), -1), order="F")
    z = coef @ problem.x1t  # (K, n)
    z -= z.max(axis=0)
    picked = float(np.vdot(target, z))  # sum_i s_i z_i,y_i / S
    np.exp(z, out=z)
    total = z.sum(axis=0)
    w = coef[:, :-1]
    loss = float(share @ np.log(total)) - picked + 0.5 * l2 * float(np.sum(w * w))
    z *= share / total
    z -= target
    grad = z @ x1  # (K, d + 1)
    grad[:, :-1] += l2 * w
    return loss, grad.ravel(order="F")


def make_problem(x, y, sample_weight, *, c: float) -> Problem:
    """The ``Problem`` of features ``x`` (n, d), classes ``y`` (n,) in 0..K-1 and
    weights ``sample_weight`` (n,) at inverse L2 strength ``c``."""
    y = np.asarray(y, dtype=np.int64)
    n, d = np.shape(x)
    x1 = np.empty((n, d + 1))
    x1[:, :d], x1[:, d] = x, 1.0
    sw = np.asarray(sample_weight, dtype=np.float64)
    share = sw / float(sw.sum())
    target = np.zeros((int(y.max()) + 1, n))
    target[y, np.arange(n)] = share
    return Problem(x1, np.ascontiguousarray(x1.T), target, share, 1.0 / (c * float(sw.sum())))


def fit_multinomial(x, y, sample_weight, *, c: float, tol: float, coef=None) -> tuple:
    """Fit W, b on ``x`` (n, d) float64, classes ``y`` (n,) in 0..K-1 (every class
    present), ``sample_weight`` (n,) s_i.

    Args:
        c: inverse L2 strength (scikit-learn's ``C``).
        tol: the solver's gradient tolerance (scikit-learn's ``tol``).
        coef: (K, d + 1) start [W b]; None: zeros.

    Returns:
        ((K, d + 1) float64 [W b], the solver's iterations).
    """
    from scipy.optimize import minimize

    problem = make_problem(x, y, sample_weight, c=c)
    k, d1 = len(problem.target), problem.x1.shape[1]
    start = np.zeros((k, d1)) if coef is None else np.asarray(coef, dtype=np.float64)
    result = minimize(
        loss_gradient,
        start.ravel(order="F"),
        method="L-BFGS-B",
        jac=True,
        args=(problem,),
        options={
            "maxiter": MAX_ITER,
            "maxls": MAX_LINE_SEARCH,
            "gtol": tol,
            "ftol": 64 * np.finfo(float).eps,
        },
    )
    return result.x.reshape((k, -1), order="F"), int(result.nit)

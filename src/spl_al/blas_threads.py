"""One BLAS/OpenMP thread for a job's numpy, scipy and scikit-learn work: ``one_thread``.

threadpoolctl limits the thread pools of the libraries loaded when its limit is
entered. scipy ships its own OpenBLAS and scikit-learn its own OpenMP runtime, each
loaded on first use: loaded inside a limit, they keep their default of one thread per
core. A pipeline job has them loaded already (the warm server imports them, and a job
without it gets Snakemake's ``OPENBLAS_NUM_THREADS``), but a bench or a notebook that
calls a step does not: there, beside a ``-j2`` run on a 2-core Xeon, L-BFGS's own
steps took 4.4 ms a call instead of ~0.03 and a street DUIS round 1.55 s instead of
0.97, with the same result. ``one_thread`` loads them first.
"""

from __future__ import annotations

from contextlib import contextmanager


@contextmanager
def one_thread():
    """Limit every BLAS and OpenMP pool of numpy, scipy and scikit-learn to one thread
    for the block, the libraries loaded first so that the limit reaches them."""
    # loaded for their thread pools: scipy's own OpenBLAS, scikit-learn's OpenMP
    import scipy.linalg
    import scipy.optimize  # noqa: F401
    import sklearn.cluster
    import sklearn.linear_model  # noqa: F401
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        yield

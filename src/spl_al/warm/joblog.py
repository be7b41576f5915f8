"""Run one workflow step with its output going to the job's log file."""

from __future__ import annotations

import contextlib
import importlib
import sys
import time
from pathlib import Path


@contextlib.contextmanager
def job_log(path, preload=()):
    """Send stdout and stderr to ``path``; a ValueError (bad input) ends the job with
    its one-sentence message in the log and on the terminal, without a traceback.

    The last line of a successful log is ``compute_seconds: X``, the time spent inside
    the block. The ``preload`` modules (the step's heavy imports: torch, pandas, ...)
    are imported before the clock starts, so benchmark wall time minus compute time is
    the job's start-up (interpreter and imports); ``python -m spl_al.bench pipeline``
    adds these up."""
    for module in preload:
        importlib.import_module(module)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    with open(path, "w", buffering=1) as log:
        old = sys.stdout, sys.stderr
        sys.stdout = sys.stderr = log
        try:
            yield log
            print(f"compute_seconds: {time.perf_counter() - started:.3f}")
        except ValueError as err:
            print(f"error: {err}")
            sys.stdout, sys.stderr = old
            print(f"error: {err} (log: {path})", file=sys.stderr)
            sys.exit(1)
        finally:
            sys.stdout, sys.stderr = old

"""Run one workflow step with its output going to the job's log file."""

from __future__ import annotations

import contextlib
import sys
import time
from pathlib import Path


@contextlib.contextmanager
def job_log(path):
    """Send stdout and stderr to ``path``; a ValueError (bad input) ends the job with
    its one-sentence message in the log and on the terminal, without a traceback."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    with open(path, "w", buffering=1) as log:
        old = sys.stdout, sys.stderr
        sys.stdout = sys.stderr = log
        try:
            yield log
            print(f"done in {time.perf_counter() - started:.2f} s")
        except ValueError as err:
            print(f"error: {err}")
            sys.stdout, sys.stderr = old
            print(f"error: {err} (log: {path})", file=sys.stderr)
            sys.exit(1)
        finally:
            sys.stdout, sys.stderr = old

"""How the tests start Snakemake."""

import sys

# --nolock: every test run writes to a folder of its own, but Snakemake keeps the locks
# of all runs in the checkout's one .snakemake/locks, and runs of the two xdist workers
# that start and end together race on those files (one run reads a lock file another
# run is deleting: FileNotFoundError: .snakemake/locks/0.input.lock).
SNAKEMAKE = [sys.executable, "-m", "snakemake", "--nolock"]

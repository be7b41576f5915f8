"""How a workflow job runs: process infrastructure, not an experiment step.

- ``server``: for a local run, one process imports torch, numpy, scikit-learn and the
  library once; each job's step runs in a child forked from it (``run_job``), or in the
  job's own process without a server.
- ``client``: the standard-library script Snakemake's shell command starts for a job
  (``python -S -P client.py``), which hands the job to the server.
- ``joblog``: a job's log (its preloads, its clock, its exit).
"""

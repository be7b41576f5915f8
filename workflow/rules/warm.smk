# Warm job processes (spl_al.warm.server): for a local run, one server imports
# torch, numpy, scikit-learn and the library once, and every job's step runs in a child
# forked from it, so a job starts in ~0.1 s instead of ~2 s. Jobs stay Snakemake jobs
# (own log, benchmark, exit code); without the server they run in their own process.
# Off on a cluster, with per-rule conda environments, and with `warm_worker: false`.
# start_warm_worker / stop_warm_worker: workflow/rules/functions/warm.smk.


onstart:
    print_jobs_line()
    start_warm_worker()


onsuccess:
    stop_warm_worker()


onerror:
    stop_warm_worker()

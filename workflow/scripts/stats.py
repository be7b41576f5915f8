from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import make_stats

with job_log(snakemake.log[0], preload=("matplotlib.pyplot", "spl_al.report")):
    make_stats(
        snakemake.input.metrics,
        snakemake.params.experiments,
        snakemake.params.sweeps,
        dict(snakemake.output.items()),
    )

from pathlib import Path

from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import make_table

with job_log(snakemake.log[0], preload=("spl_al.report",)):
    make_table(
        snakemake.input.metrics,
        snakemake.wildcards.table,
        snakemake.params.experiments,
        snakemake.params.sweeps,
        Path(snakemake.output.csv).with_suffix(""),
    )

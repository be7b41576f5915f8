from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import initial_set

with job_log(
    snakemake.log[0],
    preload=(
        "spl_al.data",
        "spl_al.pool",
    ),
):
    initial_set(
        snakemake.input[0], snakemake.params.al, int(snakemake.wildcards.seed), snakemake.output[0]
    )

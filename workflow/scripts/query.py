from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import query_round

w = snakemake.wildcards
with job_log(
    snakemake.log[0],
    preload=(
        "spl_al.pool",
        "spl_al.strategies",
    ),
):
    print(
        query_round(
            snakemake.input.scores,
            snakemake.input.labeled,
            snakemake.params.method,
            snakemake.params.batch,
            int(w.seed),
            int(w.round),
            snakemake.output[0],
        )
    )

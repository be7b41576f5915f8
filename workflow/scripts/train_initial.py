from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import train_initial

w = snakemake.wildcards
with job_log(
    snakemake.log[0],
    preload=(
        "spl_al.data",
        "spl_al.scoring",
        "spl_al.training",
    ),
) as log:
    train_initial(
        snakemake.input.data,
        snakemake.input.labeled,
        snakemake.params.setup,
        int(w.m),
        int(w.seed),
        snakemake.output.model,
        snakemake.output.fit,
        snakemake.output.scores,
        device=snakemake.params.device,
        threads=snakemake.threads,
        log=log,
    )

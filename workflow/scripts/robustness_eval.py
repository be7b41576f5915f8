from spl_al.experiment.joblog import job_log
from spl_al.experiment.robustness import evaluate_grid

with job_log(snakemake.log[0], preload=("spl_al.data", "spl_al.training")):
    evaluate_grid(
        snakemake.input.data,
        snakemake.input.grid,
        snakemake.input.models,
        snakemake.params.model,
        snakemake.params.names,
        snakemake.output[0],
        device=snakemake.params.device,
        threads=snakemake.threads,
    )

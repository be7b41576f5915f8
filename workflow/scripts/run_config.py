from spl_al.experiment.warm import run_job

run_job(
    snakemake.log[0],
    "spl_al.config:write_config",
    dict(config=snakemake.params.config, path=snakemake.output[0]),
)

from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.report_steps:write_run_config",
    dict(config=snakemake.params.config, out_path=snakemake.output[0]),
    show=True,
)

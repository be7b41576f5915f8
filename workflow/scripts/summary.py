from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.report_steps:make_summary",
    dict(
        metrics_paths=snakemake.input.metrics,
        out_path=snakemake.output[0],
        notes=snakemake.params.notes,
        families=snakemake.params.families,
    ),
    preload=("spl_al.report",),
)

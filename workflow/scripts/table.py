from pathlib import Path

from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.report_steps:make_table",
    dict(
        metrics_paths=snakemake.input.metrics,
        kind=snakemake.wildcards.table,
        experiments=snakemake.params.experiments,
        sweeps=snakemake.params.sweeps,
        out_stem=str(Path(snakemake.output.csv).with_suffix("")),
        notes=snakemake.params.notes,
    ),
    preload=("spl_al.report",),
)

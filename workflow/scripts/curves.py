from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.report_steps:make_curves",
    dict(
        metrics_paths=snakemake.input.metrics,
        methods=snakemake.params.methods,
        png=snakemake.output.png,
        pdf=snakemake.output.pdf,
        title=snakemake.wildcards.dataset,
        per_level=snakemake.params.levels,
        families=snakemake.params.families,
    ),
    preload=("matplotlib.pyplot", "spl_al.report"),
)

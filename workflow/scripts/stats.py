from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.report_steps:make_stats",
    dict(
        metrics_paths=snakemake.input.metrics,
        experiments=snakemake.params.experiments,
        sweeps=snakemake.params.sweeps,
        out=dict(snakemake.output.items()),
        claim_notes=getattr(snakemake.params, "claim_notes", None),
    ),
    preload=("matplotlib.pyplot", "spl_al.report"),
)

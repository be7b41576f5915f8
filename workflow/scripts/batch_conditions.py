from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.report_steps:make_batch_conditions",
    dict(
        dataset_path=snakemake.input.data,
        methods=snakemake.params.methods,
        rounds=snakemake.params.rounds,
        out=dict(snakemake.output.items()),
        title=snakemake.wildcards.dataset,
        framework=snakemake.params.framework,
        labeled_paths=list(getattr(snakemake.input, "labeled", [])),
        labeled_runs=getattr(snakemake.params, "labeled_runs", []),
        runs_paths=list(getattr(snakemake.input, "runs", [])),
    ),
    preload=("matplotlib.pyplot", "spl_al.report"),
)

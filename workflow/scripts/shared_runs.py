from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.embedding_steps:shared_runs",
    dict(
        runs_path=snakemake.input.runs,
        dataset_path=snakemake.input.data,
        source_path=snakemake.input.source_data,
        dataset=snakemake.wildcards.dataset,
        source=snakemake.params.source,
        out_path=snakemake.output[0],
    ),
)

from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.data_steps:merge_variants",
    dict(
        observed_path=snakemake.input.observed,
        shard_paths=snakemake.input.shards,
        out_path=snakemake.output[0],
    ),
    preload=("spl_al.data.variants",),
    show=True,
)

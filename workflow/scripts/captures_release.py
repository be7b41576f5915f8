from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.data_steps:release_captures",
    dict(
        entry=snakemake.params.entry,
        shard_paths=list(snakemake.input),
        out_dir=snakemake.output[0],
    ),
    preload=("spl_al.data",),
    show=True,
)

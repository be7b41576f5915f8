from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.robustness:make_grid_shard",
    dict(
        observed_path=snakemake.input[0],
        grid=snakemake.params.grid,
        shard=int(snakemake.wildcards.shard),
        out_path=snakemake.output[0],
    ),
    preload=("spl_al.data", "spl_al.data.variants"),
)

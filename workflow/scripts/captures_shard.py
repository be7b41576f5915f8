from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.data_steps:reconstruct_captures",
    dict(
        entry=snakemake.params.entry,
        shard=int(snakemake.wildcards.shard),
        out_path=snakemake.output[0],
        sspi_weights=snakemake.params.sspi_weights,
    ),
    preload=("spl_al.photon",),
    show=True,
)

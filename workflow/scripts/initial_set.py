from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.round0:initial_set",
    dict(
        dataset_path=snakemake.input.observed,
        al=snakemake.params.al,
        seed=int(snakemake.wildcards.seed),
        out_path=snakemake.output[0],
        embeddings=getattr(snakemake.input, "embeddings", None),
    ),
    preload=("spl_al.data", "spl_al.pool"),
)

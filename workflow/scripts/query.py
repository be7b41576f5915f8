from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.round_steps:query_round",
    dict(
        scores_path=snakemake.input.scores,
        labeled_path=snakemake.input.labeled,
        method=snakemake.params.method,
        batch=snakemake.params.batch,
        seed=int(snakemake.wildcards.seed),
        round_=int(snakemake.wildcards.round),
        out_path=snakemake.output[0],
        dataset=snakemake.wildcards.dataset,
        method_name=snakemake.wildcards.method,
    ),
    preload=("spl_al.pool", "spl_al.strategies"),
    show=True,
)

from spl_al.training.compute import Compute
from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.embedding_steps:train_encoder",
    dict(
        dataset_path=snakemake.input.data,
        dataset=snakemake.wildcards.dataset,
        encoder=snakemake.params.encoder,
        variants=snakemake.params.variants,
        out=dict(
            encoder=snakemake.output.encoder,
            card=snakemake.output.card,
            embeddings=snakemake.output.embeddings,
        ),
        compute=Compute(snakemake.params.device, snakemake.threads, "fp32"),
    ),
    preload=("spl_al.data", "spl_al.training"),
    pass_log=True,
)

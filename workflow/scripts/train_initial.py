from spl_al.experiment.step_args import ModelFiles
from spl_al.training.compute import Compute
from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.round_steps:train_initial",
    dict(
        dataset_path=snakemake.input.data,
        labeled_path=snakemake.input.labeled,
        setup=snakemake.params.setup,
        n_variants=int(snakemake.wildcards.m),
        seed=int(snakemake.wildcards.seed),
        out=ModelFiles(snakemake.output.model, snakemake.output.fit, snakemake.output.scores),
        compute=Compute(snakemake.params.device, snakemake.threads, snakemake.params.precision),
    ),
    preload=("spl_al.data", "spl_al.scoring", "spl_al.training"),
    pass_log=True,
)

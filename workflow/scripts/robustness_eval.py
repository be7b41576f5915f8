from spl_al.training.compute import Compute
from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.robustness:evaluate_grid",
    dict(
        observed_path=snakemake.input.data,
        shard_paths=snakemake.input.grid,
        model_paths=snakemake.input.models,
        model_cfg=snakemake.params.model,
        names=snakemake.params.names,
        out_path=snakemake.output[0],
        compute=Compute(snakemake.params.device, snakemake.threads, snakemake.params.precision),
    ),
    preload=("spl_al.data", "spl_al.training"),
)

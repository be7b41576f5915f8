from spl_al.training.compute import Compute
from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.deploy_steps:export_model",
    dict(
        model_path=snakemake.input.model,
        card_path=snakemake.input.card,
        dataset_path=snakemake.input.data,
        out_path=snakemake.output.onnx,
        compute=Compute(snakemake.params.device, snakemake.threads),
    ),
    preload=("spl_al.data", "spl_al.training"),
)

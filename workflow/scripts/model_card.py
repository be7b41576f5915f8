from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.deploy_steps:model_card",
    dict(
        model_path=snakemake.input.model,
        dataset_path=snakemake.input.data,
        labeled_path=snakemake.input.labeled,
        metrics_path=snakemake.input.metrics,
        facts=snakemake.params.facts,
        out_path=snakemake.output.card,
        robustness_path=snakemake.input.get("robustness"),
    ),
)

from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.data_steps:data_pictures",
    dict(
        dataset_path=snakemake.input[0],
        contact_path=snakemake.output.contact,
        variants_path=snakemake.output.variants,
    ),
    preload=("matplotlib.pyplot", "spl_al.data"),
)

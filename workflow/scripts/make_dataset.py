from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.data_steps:make_dataset",
    dict(
        entry=snakemake.params.entry,
        out_path=snakemake.output[0],
        release_dir=snakemake.params.release,
    ),
    preload=("spl_al.data",),
    show=True,
)

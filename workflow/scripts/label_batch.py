from spl_al.experiment.warm import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.human:label_batch",
    dict(
        dataset_path=snakemake.input.data,
        request_path=snakemake.input.request,
        labels_file=snakemake.params.labels_file,
        out_dir=snakemake.output[0],
    ),
    preload=("matplotlib.pyplot", "spl_al.labeling"),
    show=True,
)

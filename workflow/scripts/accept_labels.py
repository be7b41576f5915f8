from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.human:accept_labels",
    dict(
        dataset_path=snakemake.input.data,
        request_path=snakemake.input.request,
        labels_file=snakemake.params.labels_file,
        batch_dir=snakemake.input.batch,
        previous_labels=snakemake.input.before or None,
        out_labeled=snakemake.output.labeled,
        out_labels=snakemake.output.labels,
        export_file=snakemake.params.export_file,
    ),
    preload=("spl_al.data", "spl_al.labeling"),
    show=True,
)

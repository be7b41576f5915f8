from spl_al.warm.server import run_job

run_job(
    snakemake.log[0],
    "spl_al.experiment.human:label_batch",
    dict(
        dataset_path=snakemake.input.data,
        request_path=snakemake.input.request,
        labels_file=snakemake.params.labels_file,
        out_dir=snakemake.output[0],
        export_file=snakemake.params.export_file,
        model_path=snakemake.input.get("model"),
        model_cfg=snakemake.params.model_cfg,
        model_version=snakemake.params.model_version,
    ),
    preload=("matplotlib.pyplot", "spl_al.labeling", "spl_al.labeling.label_studio"),
    show=True,
)

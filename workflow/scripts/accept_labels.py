from spl_al.experiment.human import accept_labels
from spl_al.experiment.joblog import job_log

with job_log(snakemake.log[0], preload=("spl_al.data", "spl_al.labeling")):
    print(
        accept_labels(
            snakemake.input.data,
            snakemake.input.request,
            snakemake.params.labels_file,
            snakemake.input.batch,
            snakemake.input.before or None,
            snakemake.output.labeled,
            snakemake.output.labels,
        )
    )

from spl_al.experiment.human import label_batch
from spl_al.experiment.joblog import job_log

with job_log(snakemake.log[0], preload=("matplotlib.pyplot", "spl_al.labeling")):
    print(
        label_batch(
            snakemake.input.data,
            snakemake.input.request,
            snakemake.params.labels_file,
            snakemake.output[0],
        )
    )

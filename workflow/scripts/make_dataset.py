from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import make_dataset

with job_log(snakemake.log[0], preload=("spl_al.data",)):
    print(make_dataset(snakemake.params.entry, snakemake.output[0]))

from spl_al.config import write_config
from spl_al.experiment.joblog import job_log

with job_log(snakemake.log[0]):
    write_config(snakemake.params.config, snakemake.output[0])

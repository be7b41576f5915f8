from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import make_summary

with job_log(snakemake.log[0], preload=("spl_al.report",)):
    make_summary(snakemake.input.metrics, snakemake.output[0], notes=snakemake.params.notes)

from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import merge_variants

with job_log(snakemake.log[0], preload=("spl_al.variants",)):
    print(merge_variants(snakemake.input.observed, snakemake.input.shards, snakemake.output[0]))

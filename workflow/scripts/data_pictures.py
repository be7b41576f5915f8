from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import data_pictures

with job_log(
    snakemake.log[0],
    preload=(
        "matplotlib.pyplot",
        "spl_al.data",
    ),
):
    data_pictures(snakemake.input[0], snakemake.output.contact, snakemake.output.variants)

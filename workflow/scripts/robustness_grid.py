from spl_al.experiment.joblog import job_log
from spl_al.experiment.robustness import make_grid_shard

with job_log(snakemake.log[0], preload=("spl_al.data", "spl_al.variants")):
    make_grid_shard(
        snakemake.input[0],
        snakemake.params.grid,
        int(snakemake.wildcards.shard),
        snakemake.output[0],
    )

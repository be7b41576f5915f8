from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import make_variant_shard

with job_log(snakemake.log[0], preload=("spl_al.variants",)):
    print(
        make_variant_shard(
            snakemake.input[0],
            snakemake.params.variants,
            int(snakemake.wildcards.shard),
            snakemake.output[0],
            sspi_weights=snakemake.params.sspi_weights,
        )
    )

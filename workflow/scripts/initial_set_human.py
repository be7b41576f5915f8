from spl_al.experiment.human import initial_set
from spl_al.experiment.joblog import job_log

with job_log(snakemake.log[0], preload=("spl_al.data", "spl_al.labeling")):
    print(
        initial_set(
            snakemake.input[0],
            snakemake.params.al,
            int(snakemake.wildcards.seed),
            snakemake.output[0],
            oracle="human",
            seed_labels=snakemake.params.seed_labels,
        )
    )

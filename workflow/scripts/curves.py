from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import make_curves

with job_log(snakemake.log[0], preload=("matplotlib.pyplot", "spl_al.report")):
    make_curves(
        snakemake.input.metrics,
        snakemake.params.methods,
        snakemake.output.png,
        snakemake.output.pdf,
        title=snakemake.wildcards.dataset,
        per_level=snakemake.params.levels,
    )

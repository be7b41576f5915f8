from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import make_curves

out = snakemake.output
with job_log(
    snakemake.log[0],
    preload=(
        "matplotlib.pyplot",
        "spl_al.report",
    ),
):
    make_curves(
        snakemake.input.metrics,
        snakemake.params.methods,
        out.png,
        out.pdf,
        out.levels_png,
        out.levels_pdf,
        title=snakemake.wildcards.dataset,
    )

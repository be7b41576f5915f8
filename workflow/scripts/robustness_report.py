from spl_al.experiment.joblog import job_log
from spl_al.experiment.robustness import robustness_report

out = snakemake.output
with job_log(snakemake.log[0], preload=("matplotlib.pyplot", "spl_al.report")):
    robustness_report(
        snakemake.input.evals,
        snakemake.input.data,
        out.table,
        out.diff,
        out.heatmaps,
        out.diff_map,
    )

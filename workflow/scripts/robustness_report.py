from spl_al.warm.server import run_job

out = snakemake.output
run_job(
    snakemake.log[0],
    "spl_al.experiment.robustness:robustness_report",
    dict(
        eval_paths=snakemake.input.evals,
        observed_path=snakemake.input.data,
        table_csv=out.table,
        diff_csv=out.diff,
        heatmap_png=out.heatmaps,
        diff_png=out.diff_map,
    ),
    preload=("matplotlib.pyplot", "spl_al.report"),
)

from spl_al.experiment.joblog import job_log
from spl_al.experiment.steps import train_round

w = snakemake.wildcards
# Round 0 of a simulated oracle copies the shared fit and scores: no torch to load.
shared = hasattr(snakemake.input, "initial_scores")
with job_log(
    snakemake.log[0],
    preload=() if shared else ("spl_al.data", "spl_al.scoring", "spl_al.training"),
) as log:
    train_round(
        snakemake.input.data,
        snakemake.input.labeled,
        snakemake.params.setup,
        w.dataset,
        w.method,
        int(w.seed),
        int(w.round),
        snakemake.output.model,
        snakemake.output.metrics,
        snakemake.output.scores,
        device=snakemake.params.device,
        threads=snakemake.threads,
        log=log,
        labels_path=snakemake.input.labels or None,
        initial_fit=(
            (
                snakemake.input.initial_model,
                snakemake.input.initial_fit,
                snakemake.input.initial_scores,
            )
            if shared
            else None
        ),
    )

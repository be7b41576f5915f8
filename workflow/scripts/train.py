from spl_al.experiment.step_args import ModelFiles, RoundId, RoundStart
from spl_al.training.compute import Compute
from spl_al.warm.server import run_job

w = snakemake.wildcards
# Round 0 of a simulated oracle copies the shared fit and scores: no torch to load.
shared = hasattr(snakemake.input, "initial_scores")
run_job(
    snakemake.log[0],
    "spl_al.experiment.round_steps:train_round",
    dict(
        dataset_path=snakemake.input.data,
        labeled_path=snakemake.input.labeled,
        setup=snakemake.params.setup,
        which=RoundId(w.dataset, w.method, int(w.seed), int(w.round)),
        out=ModelFiles(snakemake.output.model, snakemake.output.metrics, snakemake.output.scores),
        compute=Compute(snakemake.params.device, snakemake.threads, snakemake.params.precision),
        start=RoundStart(
            initial=(
                ModelFiles(
                    snakemake.input.initial_model,
                    snakemake.input.initial_fit,
                    snakemake.input.initial_scores,
                )
                if shared
                else None
            ),
            previous_model=getattr(snakemake.input, "previous_model", None),
            labels_path=snakemake.input.labels or None,
        ),
        score=snakemake.params.score,
        embeddings=getattr(snakemake.input, "embeddings", None),
    ),
    preload=() if shared else ("spl_al.data", "spl_al.scoring", "spl_al.training"),
    pass_log=True,
)

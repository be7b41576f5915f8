from spl_al.experiment.step_args import ProbeRuns
from spl_al.warm.server import run_job

encoders = sorted(set(snakemake.params.encoders))
run_job(
    snakemake.log[0],
    "spl_al.experiment.embedding_steps:probe_runs",
    dict(
        dataset_path=snakemake.input.data,
        encoders={
            e: {"embeddings": emb, "card": card}
            for e, emb, card in zip(
                encoders, snakemake.input.embeddings, snakemake.input.cards, strict=True
            )
        },
        runs=ProbeRuns(
            dataset=snakemake.wildcards.dataset,
            method_name=snakemake.wildcards.method,
            method=snakemake.params.method,
            variants=snakemake.params.variants,
            al=snakemake.params.al,
            seeds=tuple(snakemake.params.seeds),
            rounds=snakemake.params.rounds,
            probe=snakemake.params.probe,
            encoders=tuple(snakemake.params.encoders),
        ),
        out_path=snakemake.output[0],
    ),
    preload=("spl_al.data", "spl_al.linear_probe", "spl_al.strategies"),
    pass_log=True,
)

# The embedding framework (config `datasets.{d}.embedding`): self-supervised encoders
# learned on each dataset's training pool (no label, no test image), one job per
# encoder seed, then every method's runs, all seeds and rounds in one job each, on
# the frozen embeddings of each run seed's encoder: each round fits a linear classifier
# and queries from it (spl_al.experiment.embedding_steps, spl_al.experiment.encoders).
# Its tables, figures and statistics are the supervised framework's, under
# results/{dataset}/embedding/.


rule encoder:
    input:
        data=DATASET_FILE,
    output:
        encoder=layout.encoder_file(EMBEDDING, "{eseed}", "encoder.pt"),
        card=layout.encoder_file(EMBEDDING, "{eseed}", "card.json"),
        embeddings=layout.encoder_file(EMBEDDING, "{eseed}", "embeddings.npz"),
    log:
        f"{EMBEDDING_LOGS}/encoder_seed{{eseed}}.log",
    benchmark:
        f"{EMBEDDING_BENCHMARKS}/encoder_seed{{eseed}}.tsv"
    wildcard_constraints:
        dataset=one_of(OWN_EMBEDDED),
        eseed=r"\d+",
    conda:
        "../envs/spl-al.yaml"
    threads: config["threads_per_job"]
    resources:
        mem_mb=res("encoder", "mem_mb", 4000),
        runtime=res("encoder", "runtime", 60),
        gpu=config["gpus_per_train_job"],
    params:
        job=job_params(
            encoder=lambda w: {
                **encoder_recipe(config["datasets"][w.dataset]),
                "seed": int(w.eseed),
            },
            variants=lambda w: config["datasets"][w.dataset]["variants"],
            device=config["device"],
        ),
        files=job_files,
    shell:
        python_job("encoder")


rule probe_runs:
    input:
        unpack(probe_runs_encoders),
        data=DATASET_FILE,
    output:
        f"{EMBEDDING}/runs/{{method}}.json",
    log:
        f"{EMBEDDING_LOGS}/{{method}}.log",
    benchmark:
        f"{EMBEDDING_BENCHMARKS}/{{method}}.tsv"
    wildcard_constraints:
        dataset=one_of(OWN_EMBEDDED),
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("probe_runs", "mem_mb", 2000),
        runtime=res("probe_runs", "runtime", 30),
    params:
        job=job_params(
            method=lambda w: dataset_method(
                config, w.dataset, w.method, METHODS
            ).as_dict(),
            variants=lambda w: config["datasets"][w.dataset]["variants"],
            al=lambda w: config["datasets"][w.dataset]["al"],
            probe=lambda w: embedding_entry(w.dataset).get("probe") or {},
            seeds=lambda w: probe_run_params(w)["seeds"],
            encoders=lambda w: list(run_encoders(w).values()),
            rounds=lambda w: probe_run_params(w)["rounds"],
        ),
        files=job_files,
    shell:
        python_job("probe_runs")


# A dataset that shares another's embedding framework (`embedding: {shared: SOURCE}`):
# each method's runs are the source's, relabelled, once the data files match.
rule shared_probe_runs:
    input:
        unpack(shared_runs_inputs),
    output:
        f"{EMBEDDING}/runs/{{method}}.json",
    log:
        f"{EMBEDDING_LOGS}/{{method}}.log",
    benchmark:
        f"{EMBEDDING_BENCHMARKS}/{{method}}.tsv"
    wildcard_constraints:
        dataset=one_of(SHARED_EMBEDDING),
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("shared_probe_runs", "mem_mb", 1000),
        runtime=res("shared_probe_runs", "runtime", 5),
    params:
        job=job_params(source=lambda w: SHARED_EMBEDDING[w.dataset]),
        files=job_files,
    shell:
        python_job("shared_runs")


use rule table as embedding_table with:
    input:
        metrics=lambda w: probe_runs_files(w.dataset),
    output:
        csv=report(
            layout.table_file(EMBEDDING, "{table}.csv"),
            caption="../report/table.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        md=layout.table_file(EMBEDDING, "{table}.md"),
        tex=layout.table_file(EMBEDDING, "{table}.tex"),
    log:
        f"{EMBEDDING_LOGS}/table_{{table}}.log",
    benchmark:
        f"{EMBEDDING_BENCHMARKS}/table_{{table}}.tsv"
    params:
        job=job_params(
            experiments=lambda w: experiments_of(
                config, w.dataset, METHODS, EMBEDDING_FRAMEWORK
            ),
            sweeps=lambda w: sweep_table_spec(
                config, config["datasets"][w.dataset]["variants"]["n"]
            ),
            notes=[],
        ),
        files=job_files,


use rule curves as embedding_curves with:
    input:
        metrics=lambda w: probe_runs_files(
            w.dataset,
            set(
                experiments_of(config, w.dataset, METHODS, EMBEDDING_FRAMEWORK)[
                    "budget"
                ]["methods"]
            ),
        ),
    output:
        png=report(
            layout.figure_file(EMBEDDING, "curves.png"),
            caption="../report/curves.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        pdf=layout.figure_file(EMBEDDING, "curves.pdf"),
    log:
        f"{EMBEDDING_LOGS}/curves.log",
    benchmark:
        f"{EMBEDDING_BENCHMARKS}/curves.tsv"
    params:
        job=job_params(
            methods=lambda w: experiments_of(
                config, w.dataset, METHODS, EMBEDDING_FRAMEWORK
            )["budget"]["methods"],
            levels=False,
            families=lambda w: budget_families(
                config, w.dataset, METHODS, EMBEDDING_FRAMEWORK
            ),
        ),
        files=job_files,


use rule embedding_curves as embedding_level_curves with:
    output:
        png=report(
            layout.figure_file(EMBEDDING, "level_curves.png"),
            caption="../report/level_curves.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        pdf=layout.figure_file(EMBEDDING, "level_curves.pdf"),
    log:
        f"{EMBEDDING_LOGS}/level_curves.log",
    benchmark:
        f"{EMBEDDING_BENCHMARKS}/level_curves.tsv"
    params:
        job=job_params(
            methods=lambda w: experiments_of(
                config, w.dataset, METHODS, EMBEDDING_FRAMEWORK
            )["budget"]["methods"],
            levels=True,
            families=lambda w: budget_families(
                config, w.dataset, METHODS, EMBEDDING_FRAMEWORK
            ),
        ),
        files=job_files,


use rule summary as embedding_summary with:
    input:
        metrics=lambda w: probe_runs_files(w.dataset),
    output:
        report(
            layout.table_file(EMBEDDING, "summary.json"),
            caption="../report/summary.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
    log:
        f"{EMBEDDING_LOGS}/summary.log",
    benchmark:
        f"{EMBEDDING_BENCHMARKS}/summary.tsv"
    params:
        job=job_params(
            notes=lambda w: [] if has_levels(w.dataset) else [NO_LEVELS_NOTE],
            families=lambda w: budget_families(
                config, w.dataset, METHODS, EMBEDDING_FRAMEWORK
            ),
        ),
        files=job_files,


use rule stats as embedding_stats with:
    input:
        metrics=lambda w: probe_runs_files(w.dataset),
    output:
        comparisons_csv=report(
            layout.table_file(EMBEDDING, "comparisons.csv"),
            caption="../report/comparisons.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        comparisons_md=layout.table_file(EMBEDDING, "comparisons.md"),
        claims_csv=report(
            layout.table_file(EMBEDDING, "claims.csv"),
            caption="../report/claims.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        claims_md=layout.table_file(EMBEDDING, "claims.md"),
        decomposition_csv=report(
            layout.table_file(EMBEDDING, "decomposition.csv"),
            caption="../report/decomposition.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        decomposition_md=layout.table_file(EMBEDDING, "decomposition.md"),
        aubc_png=report(
            layout.figure_file(EMBEDDING, "aubc.png"),
            caption="../report/aubc.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        aubc_pdf=layout.figure_file(EMBEDDING, "aubc.pdf"),
        differences_png=report(
            layout.figure_file(EMBEDDING, "differences.png"),
            caption="../report/differences.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        differences_pdf=layout.figure_file(EMBEDDING, "differences.pdf"),
    log:
        f"{EMBEDDING_LOGS}/stats.log",
    benchmark:
        f"{EMBEDDING_BENCHMARKS}/stats.tsv"
    params:
        job=job_params(
            experiments=lambda w: experiments_of(
                config, w.dataset, METHODS, EMBEDDING_FRAMEWORK
            ),
            sweeps=lambda w: sweep_table_spec(
                config, config["datasets"][w.dataset]["variants"]["n"]
            ),
            claim_notes=lambda w: encoder_claim_notes(
                encoder_recipe(config["datasets"][w.dataset]).get("objective", "siv"),
                config["datasets"][w.dataset]["task"],
            ),
        ),
        files=job_files,


use rule batch_conditions as embedding_batch_conditions with:
    input:
        data=DATASET_FILE,
        runs=lambda w: probe_runs_files(
            w.dataset,
            set(budget_block(w.dataset, EMBEDDING_FRAMEWORK).get("methods", [])),
        ),
    output:
        csv=report(
            layout.table_file(EMBEDDING, "batch_conditions.csv"),
            caption="../report/batch_conditions.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        png=report(
            layout.figure_file(EMBEDDING, "batch_conditions.png"),
            caption="../report/batch_conditions.rst",
            category="{dataset}",
            subcategory="Embedding framework",
        ),
        pdf=layout.figure_file(EMBEDDING, "batch_conditions.pdf"),
    log:
        f"{EMBEDDING_LOGS}/batch_conditions.log",
    benchmark:
        f"{EMBEDDING_BENCHMARKS}/batch_conditions.tsv"
    params:
        job=job_params(
            methods=lambda w: budget_block(w.dataset, EMBEDDING_FRAMEWORK).get(
                "methods", []
            ),
            rounds=lambda w: budget_block(w.dataset, EMBEDDING_FRAMEWORK).get(
                "rounds", 0
            ),
            framework=EMBEDDING_FRAMEWORK.name,
        ),
        files=job_files,

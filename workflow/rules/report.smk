# Aggregation of every round's metrics into the paper's tables, curves and summary.
# These jobs take seconds (docs/benchmarks.md#pipeline): on a cluster they run where
# Snakemake runs instead of each waiting in the queue (no effect on a local run).


localrules:
    table,
    curves,
    level_curves,
    summary,
    run_config,
    stats,
    batch_conditions,


rule table:
    input:
        metrics=lambda w: metrics_files(w.dataset),
    output:
        csv=report(
            layout.table_file(SUPERVISED_DIR, "{table}.csv"),
            caption="../report/table.rst",
            category="{dataset}",
            subcategory="Tables",
        ),
        md=layout.table_file(SUPERVISED_DIR, "{table}.md"),
        tex=layout.table_file(SUPERVISED_DIR, "{table}.tex"),
    log:
        f"{RESULTS}/logs/{{dataset}}/table_{{table}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/table_{{table}}.tsv"
    wildcard_constraints:
        table="|".join(TABLE_KINDS),
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("table", "mem_mb", 2000),
        runtime=res("table", "runtime", 10),
    params:
        job=job_params(
            experiments=lambda w: experiments_of(config, w.dataset, METHODS),
            sweeps=lambda w: sweep_table_spec(
                config, config["datasets"][w.dataset]["variants"]["n"]
            ),
            notes=lambda w: training_notes(config, w.dataset),
        ),
        files=job_files,
    shell:
        python_job("table")


rule curves:
    input:
        metrics=lambda w: budget_metrics_files(w.dataset),
    output:
        png=report(
            layout.figure_file(SUPERVISED_DIR, "curves.png"),
            caption="../report/curves.rst",
            category="{dataset}",
            subcategory="Curves",
        ),
        pdf=layout.figure_file(SUPERVISED_DIR, "curves.pdf"),
    log:
        f"{RESULTS}/logs/{{dataset}}/curves.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/curves.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("curves", "mem_mb", 2000),
        runtime=res("curves", "runtime", 10),
    params:
        job=job_params(
            methods=lambda w: experiments_of(config, w.dataset, METHODS)["budget"][
                "methods"
            ],
            levels=False,
            families=lambda w: budget_families(config, w.dataset, METHODS),
        ),
        files=job_files,
    shell:
        python_job("curves")


# Only for datasets whose images have MSPPP levels (see has_levels in common.smk).
use rule curves as level_curves with:
    output:
        png=report(
            layout.figure_file(SUPERVISED_DIR, "level_curves.png"),
            caption="../report/level_curves.rst",
            category="{dataset}",
            subcategory="Curves",
        ),
        pdf=layout.figure_file(SUPERVISED_DIR, "level_curves.pdf"),
    log:
        f"{RESULTS}/logs/{{dataset}}/level_curves.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/level_curves.tsv"
    params:
        job=job_params(
            methods=lambda w: experiments_of(config, w.dataset, METHODS)["budget"][
                "methods"
            ],
            levels=True,
            families=lambda w: budget_families(config, w.dataset, METHODS),
        ),
        files=job_files,


rule summary:
    input:
        metrics=lambda w: metrics_files(w.dataset),
    output:
        report(
            layout.table_file(SUPERVISED_DIR, "summary.json"),
            caption="../report/summary.rst",
            category="{dataset}",
            subcategory="Tables",
        ),
    log:
        f"{RESULTS}/logs/{{dataset}}/summary.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/summary.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("summary", "mem_mb", 2000),
        runtime=res("summary", "runtime", 10),
    params:
        job=job_params(
            notes=lambda w: dataset_notes(w.dataset),
            families=lambda w: budget_families(config, w.dataset, METHODS),
        ),
        files=job_files,
    shell:
        python_job("summary")


rule run_config:
    output:
        f"{RESULTS}/config.yaml",
    log:
        f"{RESULTS}/logs/run_config.log",
    benchmark:
        f"{RESULTS}/benchmarks/run_config.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("run_config", "mem_mb", 500),
        runtime=res("run_config", "runtime", 5),
    params:
        job=job_params(
            config=config,
        ),
        files=job_files,
    shell:
        python_job("run_config")


rule stats:
    input:
        metrics=lambda w: metrics_files(w.dataset),
    output:
        comparisons_csv=report(
            layout.table_file(SUPERVISED_DIR, "comparisons.csv"),
            caption="../report/comparisons.rst",
            category="{dataset}",
            subcategory="Statistics",
        ),
        comparisons_md=layout.table_file(SUPERVISED_DIR, "comparisons.md"),
        claims_csv=report(
            layout.table_file(SUPERVISED_DIR, "claims.csv"),
            caption="../report/claims.rst",
            category="{dataset}",
            subcategory="Statistics",
        ),
        claims_md=layout.table_file(SUPERVISED_DIR, "claims.md"),
        decomposition_csv=report(
            layout.table_file(SUPERVISED_DIR, "decomposition.csv"),
            caption="../report/decomposition.rst",
            category="{dataset}",
            subcategory="Statistics",
        ),
        decomposition_md=layout.table_file(SUPERVISED_DIR, "decomposition.md"),
        aubc_png=report(
            layout.figure_file(SUPERVISED_DIR, "aubc.png"),
            caption="../report/aubc.rst",
            category="{dataset}",
            subcategory="Statistics",
        ),
        aubc_pdf=layout.figure_file(SUPERVISED_DIR, "aubc.pdf"),
        differences_png=report(
            layout.figure_file(SUPERVISED_DIR, "differences.png"),
            caption="../report/differences.rst",
            category="{dataset}",
            subcategory="Statistics",
        ),
        differences_pdf=layout.figure_file(SUPERVISED_DIR, "differences.pdf"),
    log:
        f"{RESULTS}/logs/{{dataset}}/stats.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/stats.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("stats", "mem_mb", 2000),
        runtime=res("stats", "runtime", 10),
    params:
        job=job_params(
            experiments=lambda w: experiments_of(config, w.dataset, METHODS),
            sweeps=lambda w: sweep_table_spec(
                config, config["datasets"][w.dataset]["variants"]["n"]
            ),
        ),
        files=job_files,
    shell:
        python_job("stats")


# The MSPPP levels and SBRs of the frames each budget method queried, against the
# pool's (only for datasets whose images have MSPPP levels: spl_al.experiment.outputs).
rule batch_conditions:
    input:
        data=DATASET_FILE,
        labeled=lambda w: batch_labeled_files(w.dataset),
    output:
        csv=report(
            layout.table_file(SUPERVISED_DIR, "batch_conditions.csv"),
            caption="../report/batch_conditions.rst",
            category="{dataset}",
            subcategory="Statistics",
        ),
        png=report(
            layout.figure_file(SUPERVISED_DIR, "batch_conditions.png"),
            caption="../report/batch_conditions.rst",
            category="{dataset}",
            subcategory="Statistics",
        ),
        pdf=layout.figure_file(SUPERVISED_DIR, "batch_conditions.pdf"),
    log:
        f"{RESULTS}/logs/{{dataset}}/batch_conditions.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/batch_conditions.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("batch_conditions", "mem_mb", 2000),
        runtime=res("batch_conditions", "runtime", 10),
    params:
        job=job_params(
            methods=lambda w: budget_block(w.dataset).get("methods", []),
            rounds=lambda w: budget_block(w.dataset).get("rounds", 0),
            labeled_runs=lambda w: batch_runs(w.dataset),
            framework=SUPERVISED.name,
        ),
        files=job_files,
    shell:
        python_job("batch_conditions")

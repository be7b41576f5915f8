# Condition robustness map: the test split re-observed over a grid of MSPPP x SBR
# (once per dataset, in shards), each budget method's final-round models (every seed,
# one job per method) evaluated on it (forward passes only), then tables, heatmaps and
# the difference map.


# the report reads small JSON files and draws two heatmaps: seconds, off the queue
localrules:
    robustness_report,


rule robustness_grid:
    input:
        OBSERVED_FILE,
    output:
        f"{RESULTS}/{{dataset}}/robustness/grid/shard{{shard}}.npz",
    log:
        f"{RESULTS}/logs/{{dataset}}/robustness_grid_shard{{shard}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/robustness_grid_shard{{shard}}.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("robustness_grid", "mem_mb", 3000),
        runtime=res("robustness_grid", "runtime", 30),
    params:
        job=job_params(
            grid=lambda w: robustness_grid(w.dataset),
        ),
        files=job_files,
    shell:
        python_job("robustness_grid")


rule robustness_eval:
    input:
        data=OBSERVED_FILE,
        grid=robustness_shards,
        models=final_models,
    output:
        f"{RESULTS}/{{dataset}}/robustness/{{method}}.json",
    log:
        f"{RESULTS}/logs/{{dataset}}/{{method}}/robustness_eval.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{method}}/robustness_eval.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: config["threads_per_job"]
    resources:
        mem_mb=res("robustness_eval", "mem_mb", 4000),
        runtime=res("robustness_eval", "runtime", 30),
        gpu=config["gpus_per_train_job"],
    params:
        job=job_params(
            model=lambda w: config["datasets"][w.dataset]["train"]["model"],
            precision=lambda w: dataset_precision(config, w.dataset),
            names=lambda w: {
                "dataset": w.dataset,
                "method": w.method,
                "seeds": budget_experiment(w.dataset)["seeds"],
                "round": int(budget_experiment(w.dataset)["rounds"]) - 1,
            },
            device=config["device"],
        ),
        files=job_files,
    shell:
        python_job("robustness_eval")


rule robustness_report:
    input:
        data=OBSERVED_FILE,
        evals=robustness_evals,
    output:
        table=report(
            layout.table_file(SUPERVISED_DIR, "robustness.csv"),
            caption="../report/robustness_table.rst",
            category="{dataset}",
            subcategory="Robustness",
        ),
        diff=layout.table_file(SUPERVISED_DIR, "robustness_diff.csv"),
        heatmaps=report(
            layout.figure_file(SUPERVISED_DIR, "robustness.png"),
            caption="../report/robustness.rst",
            category="{dataset}",
            subcategory="Robustness",
        ),
        diff_map=report(
            layout.figure_file(SUPERVISED_DIR, "robustness_diff.png"),
            caption="../report/robustness_diff.rst",
            category="{dataset}",
            subcategory="Robustness",
        ),
    log:
        f"{RESULTS}/logs/{{dataset}}/robustness_report.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/robustness_report.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("robustness_report", "mem_mb", 2000),
        runtime=res("robustness_report", "runtime", 10),
    params:
        job=job_params(),
        files=job_files,
    shell:
        python_job("robustness_report")

# Active-learning rounds per dataset x method x seed: train (fit, evaluate, score) -> query.
# Round r trains on round r's labeled set (round 0: the seed's initial set, shared by
# every method; train_initial fits and scores its model once per number of variants
# per group, and each method's round 0 copies its part) and scores the unlabeled pool
# with the model still in memory; query of round r + 1 selects from those scores and
# writes round r + 1's labeled set.


rule initial_set:
    input:
        unpack(initial_embeddings),
        observed=OBSERVED_FILE,
    output:
        f"{RESULTS}/{{dataset}}/{{initial_dir}}/seed{{seed}}.json",
    log:
        f"{RESULTS}/logs/{{dataset}}/{{initial_dir}}_seed{{seed}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{initial_dir}}_seed{{seed}}.tsv"
    wildcard_constraints:
        dataset=one_of(SIMULATED),
        initial_dir=INITIAL_DIRS,
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("initial_set", "mem_mb", 1000),
        runtime=res("initial_set", "runtime", 5),
    params:
        job=job_params(
            al=lambda w: initial_set_params(w.dataset, w.initial_dir),
        ),
        files=job_files,
    shell:
        python_job("initial_set")


rule train_initial:
    input:
        data=DATASET_FILE,
        labeled=f"{RESULTS}/{{dataset}}/{{initial_dir}}/seed{{seed}}.json",
    output:
        model=f"{RESULTS}/{{dataset}}/{{initial_dir}}/seed{{seed}}/m{{m}}/model.pt",
        fit=f"{RESULTS}/{{dataset}}/{{initial_dir}}/seed{{seed}}/m{{m}}/fit.json",
        scores=f"{RESULTS}/{{dataset}}/{{initial_dir}}/seed{{seed}}/m{{m}}/scores.npz",
    log:
        f"{RESULTS}/logs/{{dataset}}/{{initial_dir}}_seed{{seed}}_m{{m}}_train.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{initial_dir}}_seed{{seed}}_m{{m}}_train.tsv"
    wildcard_constraints:
        dataset=one_of(SIMULATED),
        initial_dir=INITIAL_DIRS,
        m=r"\d+",
    conda:
        "../envs/spl-al.yaml"
    threads: config["threads_per_job"]
    resources:
        mem_mb=res("train_initial", "mem_mb", 4000),
        runtime=res("train_initial", "runtime", 60),
        gpu=config["gpus_per_train_job"],
    params:
        job=job_params(
            setup=lambda w: {"train": train_setup(config, w.dataset)},
            device=config["device"],
            precision=lambda w: dataset_precision(config, w.dataset),
        ),
        files=job_files,
    shell:
        python_job("train_initial")


rule train:
    input:
        unpack(initial_fit),
        unpack(warm_start_model),
        unpack(selection_embeddings),
        data=DATASET_FILE,
        labeled=labeled_input,
        labels=given_labels,
    output:
        model=f"{RUN}/round{{round}}/model.pt",
        metrics=f"{RUN}/round{{round}}/metrics.json",
        scores=f"{RUN}/round{{round}}/scores.npz",
    log:
        f"{RESULTS}/logs/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_train.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_train.tsv"
    group:
        "round_{dataset}_{method}_{seed}_{round}"
    conda:
        "../envs/spl-al.yaml"
    threads: config["threads_per_job"]
    resources:
        mem_mb=res("train", "mem_mb", 4000),
        runtime=res("train", "runtime", 60),
        gpu=config["gpus_per_train_job"],
    params:
        job=job_params(
            setup=train_params,
            score=queried_after,
            device=config["device"],
            precision=lambda w: dataset_precision(config, w.dataset),
        ),
        files=job_files,
    shell:
        python_job("train")


rule query:
    input:
        scores=lambda w: previous_round(w, "scores.npz"),
        labeled=previous_labeled,
    output:
        f"{RUN}/round{{round}}/labeled.json",
    log:
        f"{RESULTS}/logs/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_query.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_query.tsv"
    wildcard_constraints:
        round=r"[1-9]\d*",
        dataset=one_of(SIMULATED),
    group:
        query_group
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("query", "mem_mb", 4000),
        runtime=res("query", "runtime", 30),
    params:
        job=job_params(
            method=lambda w: dataset_method(
                config, w.dataset, w.method, METHODS
            ).as_dict(),
            batch=query_batch,
        ),
        files=job_files,
    shell:
        python_job("query")

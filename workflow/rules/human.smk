# Human oracle (datasets with `oracle: human`): every labeled set is a labeling batch
# a person labels. initial_set_human -> to_label_initial; query_human -> to_label_round;
# accept_labels checks the filled label file (or the Label Studio export saved in its
# place) and writes the round's labeled set and labels. Until one exists,
# accept_labels stops the run naming them. From round 1 on a batch's Label Studio
# tasks carry the predictions of the model that chose it (batch_model).


rule initial_set_human:
    input:
        unpack(initial_embeddings),
        observed=OBSERVED_FILE,
        seed_labels=lambda w: config["datasets"][w.dataset].get("seed_labels") or [],
    output:
        layout.initial_file(RESULTS, "{dataset}", "{seed}"),
    log:
        f"{RESULTS}/logs/{{dataset}}/initial_seed{{seed}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/initial_seed{{seed}}.tsv"
    wildcard_constraints:
        dataset=one_of(HUMAN),
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("initial_set_human", "mem_mb", 1000),
        runtime=res("initial_set_human", "runtime", 5),
    params:
        job=job_params(
            al=lambda w: initial_set_params(w.dataset),
            seed_labels=lambda w: config["datasets"][w.dataset].get("seed_labels"),
        ),
        files=job_files,
    shell:
        python_job("initial_set_human")


rule query_human:
    input:
        scores=lambda w: previous_round(w, "scores.npz"),
        labeled=previous_labeled,
    output:
        f"{RUN}/round{{round}}/query.json",
    log:
        f"{RESULTS}/logs/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_query.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_query.tsv"
    wildcard_constraints:
        round=r"[1-9]\d*",
        dataset=one_of(HUMAN),
    group:
        query_group
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("query_human", "mem_mb", 4000),
        runtime=res("query_human", "runtime", 30),
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


rule to_label_initial:
    input:
        data=DATASET_FILE,
        request=layout.initial_file(RESULTS, "{dataset}", "{seed}"),
    output:
        directory(f"{RESULTS}/{{dataset}}/initial/seed{{seed}}/to_label"),
    log:
        f"{RESULTS}/logs/{{dataset}}/initial_seed{{seed}}_to_label.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/initial_seed{{seed}}_to_label.tsv"
    wildcard_constraints:
        dataset=one_of(HUMAN),
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("to_label_initial", "mem_mb", 2000),
        runtime=res("to_label_initial", "runtime", 10),
    params:
        job=job_params(
            labels_file=lambda w: initial_labels_file(w.dataset, w.seed),
            export_file=lambda w: initial_labels_export(w.dataset, w.seed),
            model_cfg=None,
            model_version="",
        ),
        files=job_files,
    shell:
        python_job("label_batch")


rule to_label_round:
    input:
        unpack(batch_model),
        data=DATASET_FILE,
        request=f"{RUN}/round{{round}}/query.json",
    output:
        directory(f"{RUN}/round{{round}}/to_label"),
    log:
        f"{RESULTS}/logs/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_to_label.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_to_label.tsv"
    wildcard_constraints:
        round=r"[1-9]\d*",
        dataset=one_of(HUMAN),
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("to_label_round", "mem_mb", 2000),
        runtime=res("to_label_round", "runtime", 10),
    params:
        job=job_params(
            labels_file=labels_file,
            export_file=labels_export,
            model_cfg=lambda w: config["datasets"][w.dataset]["train"].get(
                "model", {}
            ),
            model_version=lambda w: f"{w.method} seed{w.seed} round{int(w.round) - 1}",
        ),
        files=job_files,
    shell:
        python_job("label_batch")


rule accept_labels:
    input:
        data=DATASET_FILE,
        request=labeling_request,
        batch=labeling_batch,
        before=labels_before,
        given=labels_file_if_given,
    output:
        labeled=f"{RUN}/round{{round}}/labeled.json",
        labels=f"{RUN}/round{{round}}/labels.npz",
    log:
        f"{RESULTS}/logs/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_accept_labels.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_accept_labels.tsv"
    wildcard_constraints:
        dataset=one_of(HUMAN),
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("accept_labels", "mem_mb", 2000),
        runtime=res("accept_labels", "runtime", 5),
    params:
        job=job_params(
            labels_file=labels_file,
            export_file=labels_export,
        ),
        files=job_files,
    shell:
        python_job("accept_labels")

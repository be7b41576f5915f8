# Dataset synthesis (or import), observed SPL images, and SIV variants in shards.


rule dataset:
    input:
        release=lambda w: capture_release(w.dataset),
    output:
        OBSERVED_FILE,
    log:
        f"{RESULTS}/logs/{{dataset}}/dataset.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/dataset.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: dataset_threads
    resources:
        mem_mb=res("dataset", "mem_mb", 4000),
        runtime=res("dataset", "runtime", 30),
    params:
        job=job_params(
            entry=lambda w: dataset_params(w.dataset),
            release=lambda w: capture_release(w.dataset) or None,
        ),
        files=job_files,
    shell:
        python_job("make_dataset")


rule variants_shard:
    input:
        OBSERVED_FILE,
    output:
        f"{RESULTS}/{{dataset}}/data/variants/shard{{shard}}.npz",
    log:
        f"{RESULTS}/logs/{{dataset}}/variants_shard{{shard}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/variants_shard{{shard}}.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("variants_shard", "mem_mb", 2000),
        runtime=res("variants_shard", "runtime", 30),
    params:
        job=job_params(
            variants=lambda w: config["datasets"][w.dataset]["variants"],
            sspi_weights=config["photon"].get("sspi_weights"),
        ),
        files=job_files,
    shell:
        python_job("variants_shard")


rule variants_merge:
    input:
        observed=OBSERVED_FILE,
        shards=lambda w: expand(
            f"{RESULTS}/{w.dataset}/data/variants/shard{{shard}}.npz",
            shard=range(n_shards(w.dataset)),
        ),
    output:
        DATASET_FILE,
    log:
        f"{RESULTS}/logs/{{dataset}}/variants_merge.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/variants_merge.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("variants_merge", "mem_mb", 4000),
        runtime=res("variants_merge", "runtime", 10),
    params:
        job=job_params(),
        files=job_files,
    shell:
        python_job("variants_merge")


rule data_pictures:
    input:
        DATASET_FILE,
    output:
        contact=report(
            layout.figure_file(SUPERVISED_DIR, "contact_sheet.png"),
            caption="../report/contact_sheet.rst",
            category="{dataset}",
            subcategory="Data",
        ),
        variants=report(
            layout.figure_file(SUPERVISED_DIR, "variants_sheet.png"),
            caption="../report/variants_sheet.rst",
            category="{dataset}",
            subcategory="Data",
        ),
    log:
        f"{RESULTS}/logs/{{dataset}}/data_pictures.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/data_pictures.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("data_pictures", "mem_mb", 2000),
        runtime=res("data_pictures", "runtime", 10),
    params:
        job=job_params(),
        files=job_files,
    shell:
        python_job("data_pictures")

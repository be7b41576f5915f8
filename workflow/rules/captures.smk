# Raw photon captures (source: captures) reconstructed into a release-layout folder,
# which the dataset rule then reads like any folder of depth images.


rule captures_shard:
    input:
        lambda w: capture_inputs(w.dataset, int(w.shard)),
    output:
        f"{RESULTS}/{{dataset}}/captures/shard{{shard}}.npz",
    log:
        f"{RESULTS}/logs/{{dataset}}/captures_shard{{shard}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/captures_shard{{shard}}.tsv"
    wildcard_constraints:
        dataset=one_of(CAPTURES),
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("captures_shard", "mem_mb", 4000),
        runtime=res("captures_shard", "runtime", 30),
    params:
        job=job_params(
            entry=lambda w: dataset_params(w.dataset),
            sspi_weights=config["photon"].get("sspi_weights"),
        ),
        files=job_files,
    shell:
        python_job("captures_shard")


rule captures_release:
    input:
        lambda w: expand(
            f"{RESULTS}/{w.dataset}/captures/shard{{shard}}.npz",
            shard=range(capture_shards(w.dataset)),
        ),
    output:
        directory(f"{RESULTS}/{{dataset}}/captures/release"),
    log:
        f"{RESULTS}/logs/{{dataset}}/captures_release.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/captures_release.tsv"
    wildcard_constraints:
        dataset=one_of(CAPTURES),
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("captures_release", "mem_mb", 2000),
        runtime=res("captures_release", "runtime", 10),
    params:
        job=job_params(
            entry=lambda w: dataset_params(w.dataset),
        ),
        files=job_files,
    shell:
        python_job("captures_release")

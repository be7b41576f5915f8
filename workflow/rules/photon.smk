rule photon_conditions:
    output:
        report(
            f"{RESULTS}/photon/conditions.png",
            caption="../report/photon_conditions.rst",
            category="Photon engine",
        ),
    log:
        f"{RESULTS}/logs/photon/conditions.log",
    benchmark:
        f"{RESULTS}/benchmarks/photon/conditions.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("photon_conditions", "mem_mb", 1000),
        runtime=res("photon_conditions", "runtime", 5),
    params:
        seed=config["photon"]["demo_seed"],
        method=config["photon"]["reconstruct_method"],
        sspi=sspi_args(),
    shell:
        "python -m spl_al.photon --demo {output} --seed {params.seed} "
        "--method {params.method} {params.sspi} > {log} 2>&1"


rule photon_real_capture:
    input:
        lambda w: real_capture_files()[w.capture],
    output:
        report(
            f"{RESULTS}/photon/real/{{capture}}.png",
            caption="../report/photon_real.rst",
            category="Photon engine",
        ),
    log:
        f"{RESULTS}/logs/photon/real_{{capture}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/photon/real_{{capture}}.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("photon_real_capture", "mem_mb", 1000),
        runtime=res("photon_real_capture", "runtime", 5),
    params:
        sspi=sspi_args("--sspi"),
        read=shlex.join(PICTURE_OPTIONS.cli_args()),
    shell:
        "python -m spl_al.photon --real {input} {output} {params.read} {params.sspi} "
        "> {log} 2>&1"

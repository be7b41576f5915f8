# Use the model: a round's model card beside its model.pt, and a run's final model
# exported to ONNX (checked against torch with onnxruntime on the test split) with the
# exported card beside it: results/{dataset}/models/{method}/seed{seed}/final.onnx.
# A human oracle's final model is that of the last round whose labels were given.


rule model_card:
    input:
        unpack(card_inputs),
    output:
        card=f"{RUN}/round{{round}}/model.card.json",
        markdown=f"{RUN}/round{{round}}/model.card.md",
    log:
        f"{RESULTS}/logs/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_card.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{method}}/seed{{seed}}/round{{round}}_card.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: 1
    resources:
        mem_mb=res("model_card", "mem_mb", 2000),
        runtime=res("model_card", "runtime", 10),
    params:
        job=job_params(
            facts=card_facts,
        ),
        files=job_files,
    shell:
        python_job("model_card")


rule export_onnx:
    input:
        model=lambda w: final_file(w, "model.pt"),
        card=lambda w: final_file(w, "model.card.json"),
        data=DATASET_FILE,
    output:
        onnx=f"{RESULTS}/{{dataset}}/models/{{method}}/seed{{seed}}/final.onnx",
        card=f"{RESULTS}/{{dataset}}/models/{{method}}/seed{{seed}}/final.card.json",
        markdown=f"{RESULTS}/{{dataset}}/models/{{method}}/seed{{seed}}/final.card.md",
    log:
        f"{RESULTS}/logs/{{dataset}}/{{method}}/seed{{seed}}/export_onnx.log",
    benchmark:
        f"{RESULTS}/benchmarks/{{dataset}}/{{method}}/seed{{seed}}/export_onnx.tsv"
    conda:
        "../envs/spl-al.yaml"
    threads: config["threads_per_job"]
    resources:
        mem_mb=res("export_onnx", "mem_mb", 4000),
        runtime=res("export_onnx", "runtime", 20),
    params:
        job=job_params(
            device=config["device"],
        ),
        files=job_files,
    shell:
        python_job("export_onnx")

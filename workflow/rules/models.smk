# Stage 3b: one reduced model of the chain for one scene -- the file a simulation reads
# (gimbal_reduction/solver/dynamics/chainfile.py, docs/models.md).  A simulation job never loads the four
# full body files; this rule reduces them once per (scene, model).
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).


wildcard_constraints:
    # any one path component without a dot reaches the scene check, which states the rule for
    # names (scenes.NAME_RULE) in one line, instead of a MissingRuleException
    scene="[^/.]+",


rule reduced_model:
    input:
        unpack(model_inputs),
    output:
        "results/models/{scene}/{model}.h5",
    log:
        "logs/models/{scene}/{model}.log",
    benchmark:
        "results/benchmarks/rules/models/{scene}/{model}.tsv"
    resources:
        # records: models/thesis/static-8.tsv 5.9 s, models/thesis/static-xmx-4.tsv 431.1 MB (max of 134)
        mem_mb=mem_mb(431.1),
        # a tol-EPS model on a scene outside the frozen chain (long, spin) is chosen by a verified
        # search that simulates (the tolerance bench: up to 156 s on long at 1e-8): 30 min for those
        runtime=lambda wildcards: (
            30 if wildcards.model.startswith("tol-") else runtime_min(5.9)
        ),
    params:
        code=code_hash("model"),
        scene=scene_file,
        elastic_bodies=scene_elastic_bodies,
        rankings=ranking_options,
        # the body files' config hashes are checked against the configuration (--config)
        cfg=body_files_hash,
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} model --model '{wildcards.model}' --scene {params.scene} "
        "--bodies {input.bodies} {params.rankings} --config {CONFIG} --out {output} > {log} 2>&1"

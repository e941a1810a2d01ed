# Stage 3b in bulk: the reduced models that `all`'s benchmarks read (bench.smk) and that need the body
# files alone, made by one job in one process (gimbal model with several --out files) instead of
# one job per model (rule reduced_model, models.smk): a job pays ~2 s of interpreter, imports and
# body files before its first model, and these take 0.02-0.3 s each.  Each file is the one
# reduced_model makes for it; asking for one makes the set (~5 s, from the body files alone, as
# reduced_model); every other model file (a ranking's, a scene's on request) is reduced_model's.
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).
# (scene, model) of the set: the truth of every scene whose accuracy `all` verifies, and the thesis
# models of the exponential benchmark and of the integrator table that read no ranking file
PLAIN_MODELS = [(s, "truth") for s in dict.fromkeys(ALL_ACCURACY_SCENES)] + [
    ("thesis", m)
    for m in dict.fromkeys(EXPONENTIAL_MODELS + ALL_INTEGRATOR_TABLE_MODELS)
    if m != "truth"
    and not names_mod.needs_reduction_rankings(m)
    and not names_mod.needs_load_ranking(m)
    and not names_mod.needs_basis_stage(m)
]


rule plain_models:
    """The models of PLAIN_MODELS (scene, model), in one process."""
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
    output:
        [f"results/models/{s}/{m}.h5" for s, m in PLAIN_MODELS],
    log:
        "logs/models/plain_models.log",
    benchmark:
        "results/benchmarks/rules/models/plain_models.tsv"
    resources:
        # records: models/plain_models.tsv 21.3 s (load 15 on 2 cores; 3.3 CPU s), 579.2 MB (every
        # chain is held until the first file is written)
        mem_mb=mem_mb(579.2),
        runtime=runtime_min(21.3),
    params:
        code=code_hash("model"),
        models=" ".join(f"'{m}'" for _, m in PLAIN_MODELS),
        scenes=[scene_path(s) for s, _ in PLAIN_MODELS],
        elastic_bodies=lambda wildcards: [
            list(dag_scene(s).elastic_bodies) for s, _ in PLAIN_MODELS
        ],
        # the body files' config hashes are checked against the configuration (--config)
        cfg=body_files_hash,
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} model --model {params.models} --scene {params.scenes} "
        "--bodies {input.bodies} --config {CONFIG} --out {output:q} > {log} 2>&1"


ruleorder: plain_models > reduced_model

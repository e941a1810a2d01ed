# Stage 3b in bulk: the reduced models that `all`'s benchmarks read (bench.smk), each set made by one
# job in one process (gimbal model with several --out files) instead of one job per model (rule
# reduced_model, models.smk): a job pays ~2 s of interpreter, imports and body files before its
# first model, and most models take 0.02-0.3 s.  Each file is the one reduced_model makes for it;
# asking for one of them makes its whole set (~10 s); every other model file is reduced_model's.
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).
# The truth of every scene whose accuracy `all` verifies (its converged references and checks)
BENCH_TRUTH_SCENES = list(dict.fromkeys(ALL_ACCURACY_SCENES))
# The thesis models of the exponential benchmark and of the integrator table (their truth is above)
BENCH_THESIS_MODELS = list(
    dict.fromkeys(EXPONENTIAL_MODELS + ALL_INTEGRATOR_TABLE_MODELS)
)


rule truth_models:
    """The truth model of every scene of BENCH_TRUTH_SCENES, in one process."""
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
    output:
        expand("results/models/{scene}/truth.h5", scene=BENCH_TRUTH_SCENES),
    log:
        "logs/models/truth_models.log",
    benchmark:
        "results/benchmarks/rules/models/truth_models.tsv"
    resources:
        # records: models/truth_models.tsv 21.6 s (load 8 on 2 cores; 1.8 CPU s), 309.3 MB
        mem_mb=mem_mb(309.3),
        runtime=runtime_min(21.6),
    params:
        code=code_hash("model"),
        scenes=[scene_path(s) for s in BENCH_TRUTH_SCENES],
        elastic_bodies=lambda wildcards: [
            list(dag_scene(s).elastic_bodies) for s in BENCH_TRUTH_SCENES
        ],
        # the body files' config hashes are checked against the configuration (--config)
        cfg=body_files_hash,
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} model --model truth --scene {params.scenes} "
        "--bodies {input.bodies} --config {CONFIG} --out {output} > {log} 2>&1"


rule thesis_models:
    """The models of BENCH_THESIS_MODELS on scene thesis, in one process."""
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        load_ranking="results/reduction/load/thesis.h5",
        cb=(
            expand("results/reduction/cb/body{n}.h5", n=RINGS)
            if any(names_mod.needs_basis_stage(m) for m in BENCH_THESIS_MODELS)
            else []
        ),
    output:
        [f"results/models/thesis/{m}.h5" for m in BENCH_THESIS_MODELS],
    log:
        "logs/models/thesis_models.log",
    benchmark:
        "results/benchmarks/rules/models/thesis_models.tsv"
    resources:
        # records: models/thesis_models.tsv 35.5 s (load 5 on 2 cores; 1.8 CPU s), 296.4 MB
        mem_mb=mem_mb(296.4),
        runtime=runtime_min(35.5),
    params:
        code=code_hash("model"),
        scene=scene_path("thesis"),
        elastic_bodies=lambda wildcards: list(dag_scene("thesis").elastic_bodies),
        models=" ".join(f"'{m}'" for m in BENCH_THESIS_MODELS),
        # (reduce_model reads the load ranking only for load- and global- models)
        rankings=lambda wildcards, input: " ".join(
            [
                f"--reductions {' '.join(input.reductions)}",
                f"--load-ranking {input.load_ranking}",
            ]
            + ([f"--cb-bases {' '.join(input.cb)}"] if input.cb else [])
        ),
        # the body files' config hashes are checked against the configuration (--config)
        cfg=body_files_hash,
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} model --model {params.models} --scene {params.scene} "
        "--bodies {input.bodies} {params.rankings} --config {CONFIG} --out {output:q} > {log} 2>&1"


ruleorder: truth_models > reduced_model
ruleorder: thesis_models > reduced_model

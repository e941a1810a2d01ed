# Stage 4: the flexible multibody simulation of the gimbal chain, any scene and reduced model.
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).


rule kernels:
    """Make the dynamics kernels ready before the jobs that use them (gimbal_reduction.solver.dynamics.warmup):
    seconds with the kernels' extension (make install builds it: kernels.extension); without it the
    one JIT compilation into Numba's on-disk cache, beside the FE jobs at the start of a fresh clone's run.
    """
    input:
        scenes=[scene_path(s) for s in WARMUP_SCENES],
    output:
        KERNELS,
    log:
        "logs/sim/kernels.log",
    benchmark:
        "results/benchmarks/rules/kernels.tsv"
    resources:
        # no record; a cold JIT cache, two single runs per version: Numba 0.60 118 s of CPU (119 s
        # wall, quiet machine) and 143 s (loaded: 225-288 s wall), Numba 0.68 81 s (82 s wall,
        # quiet) and 97 s (274 s wall at load 4.5 on 2 cores); with the thin wrappers and the
        # step loop's stages inlined (docs/dynamics.md Section 8) 85 s, median of 3 (190-284 s
        # wall, load ~4), against 101 s for the code before in the same conditions; ~300 MB.
        # With the extension: a few seconds
        mem_mb=mem_mb(300.0),
        runtime=runtime_min(288.0),
    params:
        code=code_hash("warmup"),
        integrator=cfgmod.value(config, "simulation.integrator"),
        options=integrator_options,
    message:
        "Dynamics kernels: from their extension (make install) in seconds, or else compiled into "
        "Numba's on-disk cache once per clone (~1.5 CPU-minutes alone, several beside the FE jobs); "
        "progress below and in {log}"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} warmup --scenes {input.scenes} "
        "--integrator {params.integrator} {params.options} --out {output} 2>&1 | tee {log}"


rule load_ranking:
    input:
        scene=scene_file,
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        kernels=ancient(KERNELS),
    output:
        "results/reduction/load/{scene}.h5",
    log:
        "logs/reduction/load_{scene}.log",
    benchmark:
        "results/benchmarks/rules/load_ranking_{scene}.tsv"
    resources:
        # records: load_ranking_thesis.tsv 385.0 s, 738.1 MB (max of 6)
        mem_mb=mem_mb(738.1),
        runtime=runtime_min(385.0),
    params:
        code=code_hash("load-ranking"),
        scene=scene_file,
        cfg=body_files_hash,  # the body and reduction files are checked against the config
    message:
        "Load-aware ranking of scene {wildcards.scene}: the rigid chain's loads on each body (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} load-ranking --scene {params.scene} --bodies {input.bodies} "
        "--reductions {input.reductions} --config {CONFIG} --out {output} > {log} 2>&1"


rule simulate:
    input:
        # the model file; a bad scene or model name stops the DAG build in one line
        model=model_file,
        kernels=ancient(KERNELS),
    output:
        "results/sim/{scene}/{model}.h5",
    log:
        "logs/sim/{scene}/{model}.log",
    benchmark:
        "results/benchmarks/rules/sim/{scene}/{model}.tsv"
    resources:
        # records: sim/thesis/truth.tsv 301.6 s, 780.5 MB (max of 121)
        mem_mb=mem_mb(780.5),
        runtime=runtime_min(301.6),
    params:
        # the scene's physics (not what it needs, nor its comments) triggers a rerun; a
        # missing scene file is reported in one line when the DAG is built
        physics=scene_physics_hash,
        scene=scene_file,
        code=code_hash("simulate"),
        # config simulation: the integrator (exponential or rk4, the thesis's) and its options
        integrator=cfgmod.value(config, "simulation.integrator"),
        options=integrator_options,
        # the model's body files are checked against the configuration (--config)
        cfg=body_files_hash,
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} simulate --scene {params.scene} --model-file {input.model} "
        "--integrator {params.integrator} {params.options} --config {CONFIG} --out {output} > {log} 2>&1"


rule dynamics_verification:
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
    output:
        verification="results/verification/dynamics.json",
        benchmark="results/benchmarks/dynamics.json",
    log:
        "logs/sim/verification.log",
    benchmark:
        "results/benchmarks/rules/dynamics_verification.tsv"
    threads: TIMING_CORES  # alone (common.smk, TIMING_CORES)
    resources:
        **TIMING_RESOURCES,
        # no record: estimate, 2 GB and 1 h (JAX oracle and timed runs)
        mem_mb=2000,
        runtime=60,
    params:
        code=code_hash("verify-dynamics"),
        cfg=body_files_hash,  # the input files are checked against the config
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 {GIMBAL} verify-dynamics --bodies {input.bodies} "
        "--reductions {input.reductions} --verification {output.verification} "
        "--benchmark {output.benchmark} --config {CONFIG} > {log} 2>&1"


rule scene:
    """snakemake results/sim/{scene}/needs.done: exactly the simulations the scene declares."""
    input:
        lambda wildcards: scene_simulations(wildcards.scene),
    output:
        touch("results/sim/{scene}/needs.done"),


rule dynamics:
    input:
        # when the DAG is built (its model names are checked against the config's mode count)
        lambda wildcards: scene_simulations("thesis"),
        "results/verification/dynamics.json",


# `all`'s version (results/all/): the same checks, beside other jobs: the truth's default DOP853 run
# taken from the converged reference of thesis (the same setting), its convergence checked against the
# exponential integrator's tight reference of thesis (a second method) instead of a DOP853 run at half
# its step (~100 s), the benchmark's integrators once for their E and steps, untimed: RK4 and
# generalised-alpha from pareto_errors_all's truth rows (the same settings against the same reference;
# the truth's times alone: pareto_all's truth rows); the exponential integrator's energy and
# momentum drift over the first second of free_10s (10 s in `verify`: ~35 s)
rule dynamics_verification_all:
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        reference="results/reference/thesis/truth.h5",
        second="results/all/reference/thesis/truth.h5",
        pareto_errors="results/all/benchmarks/pareto_errors.csv",
        kernels=ancient(KERNELS),
    output:
        verification="results/all/verification/dynamics.json",
        benchmark="results/all/benchmarks/dynamics.json",
    log:
        "logs/all/dynamics_verification.log",
    benchmark:
        "results/benchmarks/rules/all/dynamics_verification.tsv"
    resources:
        mem_mb=2000,
        runtime=60,
    params:
        code=code_hash("verify-dynamics"),
        cfg=body_files_hash,
        conservation_s=1.0,
    message:
        "Dynamics against the independent JAX oracle and DOP853 (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} verify-dynamics --untimed --bodies {input.bodies} "
        "--reductions {input.reductions} --reference {input.reference} "
        "--convergence-reference {input.second} --runs-from {input.pareto_errors} "
        "--conservation-duration {params.conservation_s} "
        "--verification {output.verification} --benchmark {output.benchmark} --config {CONFIG} > {log} 2>&1"

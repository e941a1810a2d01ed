# Stage 2: shell/solid models and the 100 lowest supported modes of every body.
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).


rule modes_body:
    input:
        mesh="results/mesh/body{n}.msh",
        meta="results/mesh/body{n}.json",
    output:
        "results/modes/body{n}.h5",
    log:
        "logs/modes/body{n}.log",
    benchmark:
        "results/benchmarks/rules/modes_body{n}.tsv"
    resources:
        # records: modes_body5.tsv 21.6 s, 420.5 MB (max of 4, one rank); two ranks on a cluster
        # (workflow/profiles/slurm: mpi="srun", tasks=2), each at most the serial peak: 2 x mem
        mem_mb=2 * mem_mb(420.5),
        runtime=runtime_min(21.6),
        # the MPI launcher: none locally (one process, as always); "srun" in the Slurm profile
        mpi="",
        tasks=1,
    params:
        code=code_hash("modes"),
        # gimbal_reduction.workflow.config.body_inputs: what the stage reads (and the body file's config_hash)
        cfg=body_hash(),
    message:
        "Modes of body {wildcards.n}: DOLFINx shells and SLEPc, 100 modes (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {resources.mpi} {GIMBAL} modes --body {wildcards.n} --mesh {input.mesh} "
        "--mesh-meta {input.meta} --out {output} --config {CONFIG} > {log} 2>&1"


rule modes:
    input:
        expand("results/modes/body{n}.h5", n=BODIES),


rule modes_benchmark:
    input:
        rules.modes.input,
    output:
        "results/benchmarks/modes.json",
    log:
        "logs/modes/benchmark.log",
    resources:
        # no record: reads four body files' attributes (seconds, as verify_fe_fast)
        mem_mb=mem_mb(193.8),
        runtime=runtime_min(4.1),
    params:
        code=code_hash("bench-summary"),
    shell:
        "{GIMBAL} bench-summary modes {input} --out {output} > {log} 2>&1"


rule mode_shapes_body:
    """Print-ready mode shapes (the lowest and the best XMX-ranked modes) and the static correction
    modes of one body, with their captions in a small manifest (gimbal_reduction.results.study.mode_shapes).
    """
    input:
        body="results/modes/body{n}.h5",
        mesh="results/mesh/body{n}.msh",
        reduction="results/reduction/body{n}.h5",
    output:
        png=report(
            "results/figures/mode_shapes_body{n}.png",
            category="Figures",
            subcategory="Mode shapes",
            caption="../report/mode_shapes.rst",
        ),
        static_png=report(
            "results/figures/static_modes_body{n}.png",
            category="Figures",
            subcategory="Mode shapes",
            caption="../report/static_modes.rst",
        ),
        manifest="results/figures/mode_shapes_body{n}.json",
        vtu="results/modes/shapes/body{n}.vtu",
    log:
        "logs/modes/shapes_body{n}.log",
    benchmark:
        "results/benchmarks/rules/mode_shapes_body{n}.tsv"
    resources:
        # records: mode_shapes_body3.tsv 6.6 s, mode_shapes_body2.tsv 171.2 MB (max of 8)
        mem_mb=mem_mb(171.2),
        runtime=runtime_min(6.6),
    params:
        code=code_hash("mode-shapes"),
        cfg=body_hash(),  # the body and reduction files are checked against the config
    shell:
        "MPLBACKEND=Agg {GIMBAL} mode-shapes --body-file {input.body} --mesh {input.mesh} "
        "--reduction {input.reduction} --png {output.png} --static-png {output.static_png} "
        "--manifest {output.manifest} --vtu {output.vtu} --config {CONFIG} > {log} 2>&1"


rule mode_shapes:
    input:
        expand("results/figures/mode_shapes_body{n}.png", n=BODIES),

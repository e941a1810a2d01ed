# Stage 2: shell/solid models and the 100 lowest supported modes of every body.
# Lints left, justified in common.smk (above PY): the rules' shell commands use PY, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).


rule modes_body:
    input:
        mesh="results/mesh/body{n}.msh",
        meta="results/mesh/body{n}.json",
    output:
        "results/modes/body{n}.h5",
    params:
        code=code_hash("solver.fe.modes"),
        # workflow.config.body_inputs: what the stage reads (and the body file's config_hash)
        cfg=body_hash(),
    log:
        "logs/modes/body{n}.log",
    benchmark:
        "results/benchmarks/rules/modes_body{n}.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.fe.modes --body {wildcards.n} --mesh {input.mesh} "
        "--mesh-meta {input.meta} --out {output} --config {CONFIG} > {log} 2>&1"


rule modes:
    input:
        expand("results/modes/body{n}.h5", n=BODIES),


rule modes_benchmark:
    input:
        rules.modes.input,
    output:
        "results/benchmarks/modes.json",
    params:
        code=code_hash("results.bench.summary"),
    log:
        "logs/modes/benchmark.log",
    shell:
        "{PY} -m results.bench.summary modes {input} --out {output} > {log} 2>&1"


rule mode_shapes_body:
    """Print-ready mode shapes (the lowest and the best XMX-ranked modes) and the static correction
    modes of one body, with their captions in a small manifest (results.study.mode_shapes)."""
    input:
        body="results/modes/body{n}.h5",
        mesh="results/mesh/body{n}.msh",
        reduction="results/reduction/body{n}.h5",
    output:
        png="results/figures/mode_shapes_body{n}.png",
        static_png="results/figures/static_modes_body{n}.png",
        manifest="results/figures/mode_shapes_body{n}.json",
        vtu="results/modes/shapes/body{n}.vtu",
    params:
        code=code_hash("results.study.mode_shapes"),
    log:
        "logs/modes/shapes_body{n}.log",
    benchmark:
        "results/benchmarks/rules/mode_shapes_body{n}.tsv"
    shell:
        "MPLBACKEND=Agg {PY} -m results.study.mode_shapes --body-file {input.body} --mesh {input.mesh} "
        "--reduction {input.reduction} --png {output.png} --static-png {output.static_png} "
        "--manifest {output.manifest} --vtu {output.vtu} > {log} 2>&1"


rule mode_shapes:
    input:
        expand("results/figures/mode_shapes_body{n}.png", n=BODIES),

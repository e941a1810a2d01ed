# Stage 2: shell/solid models and the 100 lowest supported modes of every body.


rule modes_body:
    input:
        MODES_CODE,
        mesh="results/mesh/body{n}.msh",
    output:
        "results/modes/body{n}.h5",
    params:
        cfg=body_hash,
    log:
        "logs/modes/body{n}.log",
    benchmark:
        "results/benchmarks/rules/modes_body{n}.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.fe.modes --body {wildcards.n} --mesh {input.mesh} "
        "--out {output} --config {CONFIG} > {log} 2>&1"


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
    shell:
        "{PY} -m results.bench.summary modes {input} --out {output} > {log} 2>&1"


rule mode_shapes_body:
    input:
        "results/modes/body{n}.h5",
        "results/study/mode_shapes.py",
        mesh="results/mesh/body{n}.msh",
    output:
        png="results/figures/mode_shapes_body{n}.png",
        vtu="results/modes/shapes/body{n}.vtu",
    log:
        "logs/modes/shapes_body{n}.log",
    benchmark:
        "results/benchmarks/rules/mode_shapes_body{n}.tsv"
    shell:
        "{PY} -m results.study.mode_shapes --body-file {input[0]} --mesh {input.mesh} --png {output.png} "
        "--vtu {output.vtu} > {log} 2>&1"


rule mode_shapes:
    input:
        expand("results/figures/mode_shapes_body{n}.png", n=BODIES),

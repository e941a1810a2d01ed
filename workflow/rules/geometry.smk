# Stage 1: gmsh meshes of the three rings (shell mid-surfaces) and the platform (solid).
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).


rule mesh_body:
    output:
        mesh="results/mesh/body{n}.msh",
        meta="results/mesh/body{n}.json",
    log:
        "logs/mesh/body{n}.log",
    benchmark:
        "results/benchmarks/rules/mesh_body{n}.tsv"
    resources:
        # records: mesh_body4.tsv 1.7 s, 106.3 MB (max of 4)
        mem_mb=mem_mb(106.3),
        runtime=runtime_min(1.7),
    params:
        code=code_hash("mesh"),
        # what the mesh reads: the body's shape, its and (a ring) the next body's motor side, size, angles
        cfg=body_hash("mesh"),
    shell:
        "{GIMBAL} mesh --body {wildcards.n} --out {output.mesh} --meta {output.meta} --config {CONFIG} "
        "> {log} 2>&1"


rule mesh:
    input:
        expand("results/mesh/body{n}.msh", n=BODIES),

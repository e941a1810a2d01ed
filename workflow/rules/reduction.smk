# Stage 3: momentum coefficients, Hughes-identity rankings and static correction modes.
# (gimbal_reduction/reduction/load_aware.py is the scene-dependent ranking, dynamics.smk)
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG, COARSE_SIZE from outside
# the rule; no rule names a conda environment or container (the project's .venv).
# the coarse mesh of the discrete Hughes identities (every supported mode, dense solve), in: they hold
# on any mesh, so the coarsest gmsh makes of body 4 (gimbal_reduction.geometry.mesh --coarse: 192 cells from 0.65 in up,
# 2538 modes; 0.5 in, the band's width, gave 256 cells and 3386 modes at 3x the dense solve's cost)
COARSE_SIZE = 0.75


rule reduction_body:
    input:
        body="results/modes/body{n}.h5",
    output:
        "results/reduction/body{n}.h5",
    log:
        "logs/reduction/body{n}.log",
    benchmark:
        "results/benchmarks/rules/reduction_body{n}.tsv"
    resources:
        # records: reduction_body5.tsv 5.0 s, 376.5 MB (max of 4)
        mem_mb=mem_mb(376.5),
        runtime=runtime_min(5.0),
    params:
        code=code_hash("reduce"),
        cfg=body_hash(),  # the body file's config_hash is checked against the config
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} reduce --body-file {input.body} --config {CONFIG} "
        "--out {output} > {log} 2>&1"


# The rings' Craig-Bampton stage (gimbal_reduction/reduction/bases.py): one more modal solve per ring,
# the fixed-interface modes, made only for the models and studies that ask for a cb- model.
rule cb_stage:
    input:
        body="results/modes/body{n}.h5",
    output:
        "results/reduction/cb/body{n}.h5",
    log:
        "logs/reduction/cb_body{n}.log",
    benchmark:
        "results/benchmarks/rules/cb_stage_body{n}.tsv"
    wildcard_constraints:
        n="[234]",
    resources:
        # no record: 27.5 s, 100 fixed-interface modes of body 2 (9504 DOFs), measured by hand
        mem_mb=mem_mb(800.0),
        runtime=runtime_min(27.5),
    params:
        code=code_hash("cb-modes"),
        cfg=body_hash(),  # the body file's config_hash is checked against the config
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} cb-modes --body-file {input.body} --config {CONFIG} "
        "--out {output} > {log} 2>&1"


rule reduction:
    input:
        expand("results/reduction/body{n}.h5", n=BODIES),


# A coarse body with EVERY supported mode (dense solve), for the discrete Hughes identities.
rule coarse_body_all_modes:
    input:
        mesh="results/verification/coarse/body4.msh",
        meta="results/verification/coarse/body4.json",
    output:
        "results/verification/coarse/body4.h5",
    log:
        "logs/reduction/coarse_body4.log",
    benchmark:
        "results/benchmarks/rules/coarse_body_all_modes.tsv"
    resources:
        # no record at 0.75 in: 6.9 s, 655.8 MB measured (max of 3, /usr/bin/time)
        mem_mb=mem_mb(655.8),
        runtime=runtime_min(6.9),
    params:
        code=code_hash("modes"),
        cfg=body_hash(body=4, mesh_size=COARSE_SIZE),
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} modes --body 4 --mesh {input.mesh} --mesh-meta {input.meta} "
        "--out {output} --all-modes --config {CONFIG} > {log} 2>&1"


rule coarse_mesh:
    output:
        mesh="results/verification/coarse/body4.msh",
        meta="results/verification/coarse/body4.json",
    log:
        "logs/reduction/coarse_mesh4.log",
    benchmark:
        "results/benchmarks/rules/coarse_mesh.tsv"
    resources:
        # records: coarse_mesh.tsv 1.6 s, 106.3 MB
        mem_mb=mem_mb(106.3),
        runtime=runtime_min(1.6),
    params:
        code=code_hash("mesh"),
        cfg=body_hash("mesh", body=4, mesh_size=COARSE_SIZE),
    shell:
        "{GIMBAL} mesh --body 4 --size {COARSE_SIZE} --coarse --out {output.mesh} --meta {output.meta} "
        "--config {CONFIG} > {log} 2>&1"


rule reduction_report:
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        coarse="results/verification/coarse/body4.h5",
    output:
        table="results/tables/ranking.csv",
        verification="results/verification/reduction.json",
        benchmark="results/benchmarks/reduction.json",
    log:
        "logs/reduction/report.log",
    benchmark:
        "results/benchmarks/rules/reduction_report.tsv"
    resources:
        # records: reduction_report.tsv 31.0 s, 601.1 MB (max of 2)
        mem_mb=mem_mb(601.1),
        runtime=runtime_min(31.0),
    params:
        code=code_hash("reduction-report"),
        cfg=body_files_hash,  # the body and reduction files are checked against the config
    # one timed run per body: the timing repeats are the bench's (rule reduction_benchmark)
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} reduction-report --bodies {input.bodies} --reductions {input.reductions} "
        "--coarse-body {input.coarse} --table {output.table} --verification {output.verification} "
        "--benchmark {output.benchmark} --runs 1 --config {CONFIG} > {log} 2>&1"


rule reduction_benchmark:
    """The reduction stage's run time, median of 5 runs per body (gimbal_reduction.reduction.report --runs 5; its
    table and checks again, beside the timing)."""
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        coarse="results/verification/coarse/body4.h5",
    output:
        table="results/benchmarks/reduction_stage/ranking.csv",
        verification="results/benchmarks/reduction_stage/verification.json",
        benchmark="results/benchmarks/reduction_stage.json",
    log:
        "logs/reduction/benchmark.log",
    benchmark:
        "results/benchmarks/rules/reduction_benchmark.tsv"
    resources:
        # no record: reduction_report.tsv 31.0 s, 601.1 MB (max of 2) with 3 runs; 5 runs ~50 s
        mem_mb=mem_mb(601.1),
        runtime=runtime_min(60.0),
    params:
        code=code_hash("reduction-report"),
        cfg=body_files_hash,  # the body and reduction files are checked against the config
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} reduction-report --bodies {input.bodies} --reductions {input.reductions} "
        "--coarse-body {input.coarse} --table {output.table} --verification {output.verification} "
        "--benchmark {output.benchmark} --runs 5 --config {CONFIG} > {log} 2>&1"

# Stage 3: momentum coefficients, Hughes-identity rankings and static correction modes.
# the reduction stage proper; reduction/load_aware.py is the scene-dependent ranking (dynamics.smk)
REDUCTION_CODE = COMMON_CODE + [str(p) for p in sorted(Path("reduction").glob("*.py")) if p.name != "load_aware.py"]


rule reduction_body:
    input:
        REDUCTION_CODE,
        body="results/modes/body{n}.h5",
    output:
        "results/reduction/body{n}.h5",
    log:
        "logs/reduction/body{n}.log",
    benchmark:
        "results/benchmarks/rules/reduction_body{n}.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m reduction.stage --body-file {input.body} --out {output} > {log} 2>&1"


rule reduction:
    input:
        expand("results/reduction/body{n}.h5", n=BODIES),


# A coarse body with EVERY supported mode (dense solve), for the discrete Hughes identities.
rule coarse_body_all_modes:
    input:
        MODES_CODE,
        mesh="results/verification/coarse/body4.msh",
    output:
        "results/verification/coarse/body4.h5",
    log:
        "logs/reduction/coarse_body4.log",
    benchmark:
        "results/benchmarks/rules/coarse_body_all_modes.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.fe.modes --body 4 --mesh {input.mesh} --out {output} --all-modes "
        "--config {CONFIG} > {log} 2>&1"


rule coarse_mesh:
    input:
        GEOMETRY_CODE,
    output:
        "results/verification/coarse/body4.msh",
    log:
        "logs/reduction/coarse_mesh4.log",
    benchmark:
        "results/benchmarks/rules/coarse_mesh.tsv"
    shell:
        "{PY} -m geometry.mesh --body 4 --size 0.5 --out {output} --config {CONFIG} > {log} 2>&1"


rule reduction_report:
    input:
        REDUCTION_CODE,
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
    shell:
        "OMP_NUM_THREADS=1 {PY} -m reduction.report --bodies {input.bodies} --reductions {input.reductions} "
        "--coarse-body {input.coarse} --table {output.table} --verification {output.verification} "
        "--benchmark {output.benchmark} > {log} 2>&1"

# Verification of the finite-element stage: each check is its own job
# (results/verification/parts/*.json), combined into results/verification/fe.json.
VERIFY_CODE = MODES_CODE + ["solver/fe/checks.py", "solver/fe/verify.py", "solver/bodydata.py",
                            "geometry/gimbal.py", "geometry/mesh.py", "geometry/verification.py"]
GLOBAL_CHECKS = ["ring", "plate", "solid-ring", "platform", "hughes", "connection"]


rule verify_check:
    input:
        VERIFY_CODE,
    output:
        "results/verification/parts/{check}.json",
    wildcard_constraints:
        check="|".join(GLOBAL_CHECKS),
    params:
        cfg=config_hash("material", "bodies", "shell", "mesh", "eccentric_mass", "bearing_connection"),
    log:
        "logs/verification/{check}.log",
    benchmark:
        "results/benchmarks/rules/verify_{check}.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.fe.verify {wildcards.check} --config {CONFIG} --out {output} > {log} 2>&1"


rule verify_convergence:
    input:
        VERIFY_CODE,
    output:
        "results/verification/parts/convergence_body{n}.json",
    params:
        cfg=body_hash,
    log:
        "logs/verification/convergence_body{n}.log",
    benchmark:
        "results/benchmarks/rules/verify_convergence_body{n}.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.fe.verify convergence --body {wildcards.n} --config {CONFIG} "
        "--out {output} > {log} 2>&1"


rule verify_body:
    input:
        VERIFY_CODE,
        body="results/modes/body{n}.h5",
    output:
        modes="results/verification/parts/body_file_body{n}.json",
        spectra="results/verification/parts/spectra_body{n}.json",
    log:
        "logs/verification/body{n}.log",
    benchmark:
        "results/benchmarks/rules/verify_body{n}.tsv"
    shell:
        "({PY} -m solver.fe.verify body-file --body-file {input.body} --config {CONFIG} --out {output.modes} && "
        "{PY} -m solver.fe.verify spectra --body-file {input.body} --config {CONFIG} --out {output.spectra}) "
        "> {log} 2>&1"


rule verify_mpi:
    input:
        VERIFY_CODE,
        body="results/modes/body2.h5",
        mesh="results/mesh/body2.msh",
    output:
        "results/verification/parts/mpi.json",
    threads: 2
    log:
        "logs/verification/mpi.log",
    benchmark:
        "results/benchmarks/rules/verify_mpi.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.fe.verify mpi --body-file {input.body} --mesh {input.mesh} "
        "--config {CONFIG} --out {output} > {log} 2>&1"


rule verify_fe:
    input:
        expand("results/verification/parts/{check}.json", check=GLOBAL_CHECKS),
        expand("results/verification/parts/convergence_body{n}.json", n=BODIES),
        expand("results/verification/parts/body_file_body{n}.json", n=BODIES),
        expand("results/verification/parts/spectra_body{n}.json", n=BODIES),
        "results/verification/parts/mpi.json",
    output:
        json="results/verification/fe.json",
        summary="results/verification/fe.md",
    log:
        "logs/verification/fe.log",
    benchmark:
        "results/benchmarks/rules/verify_fe.tsv"
    shell:
        "{PY} -m solver.fe.verify combine {input} --config {CONFIG} --out {output.json} "
        "--summary {output.summary} > {log} 2>&1"

# Verification of the finite-element stage: each check is its own job
# (results/verification/parts/*.json), combined into results/verification/fe.json.
# Each rule reruns when the code of solver.fe.verify changes or a config value its check reads
# (workflow.config.check_inputs).
# Lints left, justified in common.smk (above PY): the rules' shell commands use PY, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).
VERIFY_CODE = code_hash("solver.fe.verify")
GLOBAL_CHECKS = ["ring", "plate", "solid-ring", "platform", "hughes", "connection"]


rule verify_check:
    output:
        "results/verification/parts/{check}.json",
    wildcard_constraints:
        check="|".join(GLOBAL_CHECKS),
    params:
        code=VERIFY_CODE,
        cfg=check_hash(),
    log:
        "logs/verification/{check}.log",
    benchmark:
        "results/benchmarks/rules/verify_{check}.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.fe.verify {wildcards.check} --config {CONFIG} --out {output} > {log} 2>&1"


rule verify_convergence:
    output:
        "results/verification/parts/convergence_body{n}.json",
    params:
        code=VERIFY_CODE,
        cfg=check_hash("convergence"),
    log:
        "logs/verification/convergence_body{n}.log",
    benchmark:
        "results/benchmarks/rules/verify_convergence_body{n}.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.fe.verify convergence --body {wildcards.n} --config {CONFIG} "
        "--out {output} > {log} 2>&1"


rule verify_body:
    input:
        body="results/modes/body{n}.h5",
    output:
        modes="results/verification/parts/body_file_body{n}.json",
        spectra="results/verification/parts/spectra_body{n}.json",
    params:
        code=VERIFY_CODE,
        cfg=check_hash("spectra"),  # the body-file check reads no config
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
        body="results/modes/body2.h5",
        mesh="results/mesh/body2.msh",
    output:
        "results/verification/parts/mpi.json",
    params:
        # it runs the modal stage (python -m solver.fe.modes) under mpirun
        code=code_hash("solver.fe.verify", "solver.fe.modes"),
        cfg=check_hash("mpi"),
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
    params:
        code=VERIFY_CODE,
        cfg=config_hash(),  # fe.json records the hash of the whole config
    log:
        "logs/verification/fe.log",
    benchmark:
        "results/benchmarks/rules/verify_fe.tsv"
    shell:
        "{PY} -m solver.fe.verify combine {input} --config {CONFIG} --out {output.json} "
        "--summary {output.summary} > {log} 2>&1"


# The fast subset that `all` runs (issue 14: the main job in minutes): the body files against
# their contract and their spectra against the independent formulas, the thin-ring formula, the
# discrete Hughes identities and the bearing connection. The fine meshes (convergence), the solid
# ring, the plate and platform references and the MPI run are `verify` (results/verification/fe.json).
FAST_CHECKS = ["ring", "hughes", "connection"]


rule verify_fe_fast:
    input:
        expand("results/verification/parts/{check}.json", check=FAST_CHECKS),
        expand("results/verification/parts/body_file_body{n}.json", n=BODIES),
        expand("results/verification/parts/spectra_body{n}.json", n=BODIES),
    output:
        json="results/verification/fe_fast.json",
        summary="results/verification/fe_fast.md",
    params:
        code=VERIFY_CODE,
        cfg=config_hash(),
    log:
        "logs/verification/fe_fast.log",
    benchmark:
        "results/benchmarks/rules/verify_fe_fast.tsv"
    shell:
        "{PY} -m solver.fe.verify combine {input} --config {CONFIG} --out {output.json} "
        "--summary {output.summary} > {log} 2>&1"

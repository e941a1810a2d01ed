# Verification of the finite-element stage: each check is its own job
# (results/verification/parts/*.json), combined into results/verification/fe.json.
# Each rule reruns when the code of gimbal_reduction.solver.fe.verify changes or a config value its check reads
# (gimbal_reduction.workflow.config.check_inputs).
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).
VERIFY_CODE = code_hash("fe-verify")
GLOBAL_CHECKS = ["ring", "plate", "solid-ring", "platform", "hughes", "connection"]
# the coarse body with every supported mode (reduction.smk, coarse_body_all_modes): the Hughes
# check reads it instead of solving it again
COARSE_BODY = "results/verification/coarse/body4.h5"
# (s, max_rss MB) of each check's largest benchmark record (results/benchmarks/rules/verify_{check}.tsv);
# plate has no record: taken as platform's (both a plate or solid reference solve of similar size);
# hughes has no record since it reads the coarse body: 4.0 s, 442.0 MB measured (max of 3, /usr/bin/time);
# connection none since its variants are solved with multipliers: 10.2 s, 625.5 MB measured (max of 4)
VERIFY_CHECK_RECORDS = {
    "ring": (3.4, 232.8),
    "hughes": (4.0, 442.0),
    "connection": (10.2, 625.5),
    "platform": (17.2, 486.2),
    "plate": (17.2, 486.2),
    "solid-ring": (287.9, 4909.9),
}


rule verify_check:
    input:
        body=lambda wildcards: COARSE_BODY if wildcards.check == "hughes" else [],
    output:
        "results/verification/parts/{check}.json",
    log:
        "logs/verification/{check}.log",
    benchmark:
        "results/benchmarks/rules/verify_{check}.tsv"
    wildcard_constraints:
        check="|".join(GLOBAL_CHECKS),
    resources:
        # per check (VERIFY_CHECK_RECORDS above)
        mem_mb=lambda wildcards: mem_mb(VERIFY_CHECK_RECORDS[wildcards.check][1]),
        runtime=lambda wildcards: runtime_min(VERIFY_CHECK_RECORDS[wildcards.check][0]),
    params:
        code=VERIFY_CODE,
        cfg=check_hash(),
        body=lambda wildcards, input: f"--body-file {input.body}" if input.body else "",
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} fe-verify {wildcards.check} {params.body} --config {CONFIG} --out {output} "
        "> {log} 2>&1"


rule verify_convergence:
    output:
        "results/verification/parts/convergence_body{n}.json",
    log:
        "logs/verification/convergence_body{n}.log",
    benchmark:
        "results/benchmarks/rules/verify_convergence_body{n}.tsv"
    resources:
        # records: verify_convergence_body2.tsv 24.1 s, verify_convergence_body3.tsv 402.9 MB; no
        # record of body 4 (a ring: as bodies 2, 3) nor body 5: the finest level needs 7.0 GB (
        # measured; taken to be the platform, the largest mesh), its time unknown: 1 h assumed
        mem_mb=lambda wildcards: mem_mb(7000.0 if wildcards.n == "5" else 402.9),
        runtime=lambda wildcards: 60 if wildcards.n == "5" else runtime_min(24.1),
    params:
        code=VERIFY_CODE,
        cfg=check_hash("convergence"),
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} fe-verify convergence --body {wildcards.n} --config {CONFIG} "
        "--out {output} > {log} 2>&1"


rule verify_body:
    input:
        body="results/modes/body{n}.h5",
    output:
        modes="results/verification/parts/body_file_body{n}.json",
        spectra="results/verification/parts/spectra_body{n}.json",
    log:
        "logs/verification/body{n}.log",
    benchmark:
        "results/benchmarks/rules/verify_body{n}.tsv"
    resources:
        # records: verify_body5.tsv 10.5 s, 406.3 MB (max of 4)
        mem_mb=mem_mb(406.3),
        runtime=runtime_min(10.5),
    params:
        code=VERIFY_CODE,
        cfg=check_hash("spectra"),  # the body-file check reads no config
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} fe-verify body --body-file {input.body} --config {CONFIG} "
        "--out {output.modes} --spectra-out {output.spectra} > {log} 2>&1"


rule verify_mpi:
    input:
        body="results/modes/body2.h5",
        mesh="results/mesh/body2.msh",
    output:
        "results/verification/parts/mpi.json",
    log:
        "logs/verification/mpi.log",
    benchmark:
        "results/benchmarks/rules/verify_mpi.tsv"
    threads: 2
    resources:
        # no record: the modal stage of body 2 under mpirun -n 2, as modes_body on two ranks
        mem_mb=2 * mem_mb(420.5),
        runtime=runtime_min(21.6),
    params:
        # it runs the modal stage (python -m gimbal_reduction.solver.fe.modes) under mpirun
        code=code_hash("fe-verify", "modes"),
        cfg=check_hash("mpi"),
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} fe-verify mpi --body-file {input.body} --mesh {input.mesh} "
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
    resources:
        # no record: combines JSON files, as verify_fe_fast (verify_fe_fast.tsv 4.1 s, 193.8 MB)
        mem_mb=mem_mb(193.8),
        runtime=runtime_min(4.1),
    params:
        code=VERIFY_CODE,
        cfg=config_hash(),  # fe.json records the hash of the whole config
    shell:
        "{GIMBAL} fe-verify combine {input} --config {CONFIG} --out {output.json} "
        "--summary {output.summary} > {log} 2>&1"


# The fast subset that `all` runs (the main job in minutes): the body files against
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
    log:
        "logs/verification/fe_fast.log",
    benchmark:
        "results/benchmarks/rules/verify_fe_fast.tsv"
    resources:
        # records: verify_fe_fast.tsv 4.1 s, 193.8 MB
        mem_mb=mem_mb(193.8),
        runtime=runtime_min(4.1),
    params:
        code=VERIFY_CODE,
        cfg=config_hash(),
    shell:
        "{GIMBAL} fe-verify combine {input} --config {CONFIG} --out {output.json} "
        "--summary {output.summary} > {log} 2>&1"


# The truth's own error from a larger basis: the modal stage with 200 modes per body on
# the same meshes, and the truth (100 per body) against freq-200 on every study scene: the truth's run
# is the study's (results/study/{scene}/sim/truth.h5, checked), freq-200 is simulated (the 1 s scene
# long: ~39 s of the job, 800 coordinates). Part of
# `all`: the report states down to what error the truth can referee, and residual flexibility alone
# (static-100) underestimates it.
LARGE_BASIS_MODES = 200
TRUTH_BASIS_SCENES = ["thesis", "damped", "smooth", "long"]


# The truth's own error (truth_basis, ~1 min on one core) waits for these modes and for the four
# studies' truths. Left at the default priority the scheduler ran them last, and truth_basis then ran
# alone with the second core idle while the timing jobs (which need both cores) waited: 60-80 s of a
# clean `all`. Their measured priorities (workflow/priorities.json) start both when ready.
rule modes_body_large:
    input:
        mesh="results/mesh/body{n}.msh",
        meta="results/mesh/body{n}.json",
        # its 100 lowest modes are the study's (kept; only the next 100 are solved for)
        known="results/modes/body{n}.h5",
    output:
        "results/verification/truth_basis/body{n}.h5",
    log:
        "logs/verification/truth_basis_body{n}.log",
    benchmark:
        "results/benchmarks/rules/modes_body_large{n}.tsv"
    resources:
        # no record since it starts from the 100 known modes: body 5 15.7 s (max of 3), 706.4 MB
        # measured (/usr/bin/time, one rank)
        mem_mb=mem_mb(706.4),
        runtime=runtime_min(15.7),
    params:
        code=code_hash("modes"),
        cfg=body_hash(),
        modes=LARGE_BASIS_MODES,
    message:
        "Modes of body {wildcards.n} on the finer mesh (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} modes --body {wildcards.n} --mesh {input.mesh} "
        "--mesh-meta {input.meta} --count {params.modes} --known-modes {input.known} --out {output} "
        "--config {CONFIG} > {log} 2>&1"


rule truth_basis:
    input:
        bodies=expand("results/verification/truth_basis/body{n}.h5", n=BODIES),
        scenes=expand("config/scenes/{scene}.yaml", scene=TRUTH_BASIS_SCENES),
        kernels=ancient(KERNELS),
        # the study's truth of each scene (one truth simulation per scene), read and checked
        truths=expand("results/study/{scene}/sim/truth.h5", scene=TRUTH_BASIS_SCENES),
    output:
        "results/verification/truth_basis.json",
    log:
        "logs/verification/truth_basis.log",
    benchmark:
        "results/benchmarks/rules/truth_basis.tsv"
    resources:
        # records: truth_basis.tsv 340.3 s (load 11 on 2 cores; 135.8 CPU s), 1742.3 MB (E's sampling
        # rule's grids: thesis 6001, long 40001 samples)
        mem_mb=mem_mb(1742.3),
        runtime=runtime_min(340.3),
    params:
        code=code_hash("truth-basis"),
        cfg=body_files_hash,  # the body files are checked against the config
        physics=lambda wildcards: [
            scenes_mod.load_scene(f"config/scenes/{s}.yaml").config_hash()
            for s in TRUTH_BASIS_SCENES
        ],
        # read where the study runs the truth as this job does (the exponential integrator)
        truths=lambda wildcards, input: (
            " ".join(f"'{s}={f}'" for s, f in zip(TRUTH_BASIS_SCENES, input.truths))
            if cfgmod.value(config, "simulation.integrator") == "exponential"
            else ""
        ),
        tol=cfgmod.value(config, "simulation.tolerance"),
    message:
        "The truth's own error: a 200-mode truth simulated on every study scene, the study's truths read (~1 CPU-minute; log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} truth-basis --bodies {input.bodies} --scenes {input.scenes} "
        "--truths {params.truths} --tol {params.tol} --config {CONFIG} --out {output} > {log} 2>&1"


# ---- `all`'s version of fe.json (results/all/verification/fe.json): every check of `verify_fe`, two on
# coarser meshes. The solid ring at one P3 tetrahedron through the 0.25 in wall (ALL_SOLID_SIZE; 1.8 CPU s,
# 470 MB, worst of 10 modes 0.73 % from the shell, measured) instead of three (288 s, 4.9 GB); the
# platform's convergence on its levels h, h/2 (its h/4 needs 7 GB), the rings' on all three (h/2 is the
# largest and is cheap), each with level h read from the study's body file (the same mesh and solver
# as its modes: one eigensolve fewer, ~8 s of the platform's). The other parts are shared with `verify_fe`.
ALL_SOLID_SIZE = 0.25  # in: one element through body 2's 0.25 in wall (config bodies.outer_gimbal.thickness)
ALL_CONVERGENCE_LEVELS = {"ring": "-1 0 1", "plate": "0 1"}


rule verify_solid_ring_all:
    output:
        "results/all/verification/parts/solid-ring.json",
    log:
        "logs/verification/all/solid-ring.log",
    benchmark:
        "results/benchmarks/rules/all/verify_solid-ring.tsv"
    resources:
        # no record: 6.7 s wall, 1.8 CPU s, 470.6 MB measured (one run, load ~9)
        mem_mb=mem_mb(470.6),
        runtime=runtime_min(6.7),
    params:
        code=VERIFY_CODE,
        cfg=check_hash("solid-ring"),
        size=ALL_SOLID_SIZE,
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} fe-verify solid-ring --solid-size {params.size} --config {CONFIG} "
        "--out {output} > {log} 2>&1"


rule verify_convergence_all:
    input:
        # the study's modes of this body: level 0's frequencies, read rather than solved again
        body="results/modes/body{n}.h5",
    output:
        "results/all/verification/parts/convergence_body{n}.json",
    log:
        "logs/verification/all/convergence_body{n}.log",
    benchmark:
        "results/benchmarks/rules/all/verify_convergence_body{n}.tsv"
    resources:
        # as verify_convergence's rings (24.1 s, 402.9 MB); the platform on h, h/2: no record, 46.5 CPU s,
        # 1159.4 MB measured (/usr/bin/time, one run at load ~10: 284 s wall)
        mem_mb=lambda wildcards: mem_mb(1159.4 if wildcards.n == "5" else 402.9),
        runtime=lambda wildcards: runtime_min(284.0 if wildcards.n == "5" else 24.1),
    params:
        code=VERIFY_CODE,
        cfg=check_hash("convergence"),
        levels=lambda wildcards: ALL_CONVERGENCE_LEVELS[
            cfgmod.body_parameters(config, int(wildcards.n))["shape"]
        ],
    message:
        "Mesh convergence of body {wildcards.n}: all 100 modes on a finer mesh (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} fe-verify convergence --body {wildcards.n} --levels {params.levels} "
        "--body-file {input.body} --config {CONFIG} --out {output} > {log} 2>&1"


rule verify_fe_all:
    input:
        expand(
            "results/verification/parts/{check}.json",
            check=[c for c in GLOBAL_CHECKS if c != "solid-ring"],
        ),
        "results/all/verification/parts/solid-ring.json",
        expand("results/all/verification/parts/convergence_body{n}.json", n=BODIES),
        expand("results/verification/parts/body_file_body{n}.json", n=BODIES),
        expand("results/verification/parts/spectra_body{n}.json", n=BODIES),
        "results/verification/parts/mpi.json",
    output:
        json="results/all/verification/fe.json",
        summary="results/all/verification/fe.md",
    log:
        "logs/verification/all/fe.log",
    benchmark:
        "results/benchmarks/rules/all/verify_fe.tsv"
    resources:
        # as verify_fe_fast (verify_fe_fast.tsv 4.1 s, 193.8 MB)
        mem_mb=mem_mb(193.8),
        runtime=runtime_min(4.1),
    params:
        code=VERIFY_CODE,
        cfg=config_hash(),
    shell:
        "{GIMBAL} fe-verify combine {input} --config {CONFIG} --out {output.json} "
        "--summary {output.summary} > {log} 2>&1"

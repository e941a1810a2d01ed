# Stage 4: the flexible multibody simulation of the gimbal chain, any scene and reduced model.
DYNAMICS_CODE = REDUCTION_CODE + [f"solver/{name}.py" for name in (
    "multibody", "fast_rhs", "integrators", "scenes", "models", "simulate")]
DYNAMICS_CHECK_CODE = DYNAMICS_CODE + ["solver/dynamics_checks.py", "solver/verify_dynamics.py", "results/errors.py"]

wildcard_constraints:
    scene="[A-Za-z0-9_-]+",


rule simulate:
    input:
        DYNAMICS_CODE,
        "config/scenes/{scene}.yaml",
        expand("results/modes/body{n}.h5", n=BODIES),
        expand("results/reduction/body{n}.h5", n=BODIES),
    output:
        "results/sim/{scene}/{model}.h5",
    log:
        "logs/sim/{scene}/{model}.log",
    benchmark:
        "results/benchmarks/rules/sim/{scene}/{model}.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.simulate --scene {wildcards.scene} --model '{wildcards.model}' "
        "--modes-dir results/modes --reduction-dir results/reduction --out-dir results/sim > {log} 2>&1"


rule dynamics_verification:
    input:
        DYNAMICS_CHECK_CODE,
        expand("results/modes/body{n}.h5", n=BODIES),
        expand("results/reduction/body{n}.h5", n=BODIES),
    output:
        verification="results/verification/dynamics.json",
        benchmark="results/benchmarks/dynamics.json",
    log:
        "logs/sim/verification.log",
    benchmark:
        "results/benchmarks/rules/dynamics_verification.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m solver.verify_dynamics --modes-dir results/modes "
        "--reduction-dir results/reduction --verification {output.verification} "
        "--benchmark {output.benchmark} > {log} 2>&1"


rule dynamics:
    input:
        "results/sim/thesis/truth.h5",
        "results/sim/thesis/freq-10.h5",
        "results/sim/thesis/xmx-10.h5",
        "results/sim/thesis/static-8.h5",
        "results/verification/dynamics.json",

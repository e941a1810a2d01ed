# Stage 6: fast and stable. Run time against error, the right-hand side's cost
# against model size (with the dense-mass-matrix baseline timed in the same run), and the
# stability stress tests; the exponential integrator's speed table against the converged
# DOP853 references. Every benchmark writes files; nothing here is a timed assertion.
#   snakemake --cores 2 bench
# Pareto: one model per family at ~40-100 elastic coordinates (each costs ~2 min of repeated
# runs; the truth, always added, ~5 min).
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).
PARETO_MODELS = ["freq-10", "xmx-10", "load-10", "global-100"]
# Load-aware and global selection against frequency / XMX / XMGMX at equal coordinate counts
SELECTION_MODELS = (
    ["rigid"]
    + [f"{f}-{n}" for f in ("freq", "xmx", "xmgmx") for n in (5, 10, 15, 20, 25)]
    + [f"load-{n}" for n in (5, 10, 15, 20, 25, 30, 40)]
    + [f"global-{n}" for n in (20, 40, 60, 80, 100, 120, 160)]
)
# Exponential integrator speed: one reduced model per family of the study on thesis (each ~50-120
# ms a run). The benchmark's cost (loaded 2-core machine): the DOP853 comparison ~3 min (6 DOP853
# runs of 25-40 s), `long` ~2.5 min (6 runs of ~25 s), a second DOP853 comparison at the tolerance
# sweep's fastest tolerance (~80 s), the sweep itself (7 tolerances, ~5 s): ~170 s in all, one core.
EXPONENTIAL_MODELS = [
    "freq-10",
    "xmx-10",
    "xmgmx-10",
    "static-8",
    "load-10",
    "global-100",
    "rigid",
]
# Scenes whose converged DOP853 reference the exponential benchmark judges E against. Costs of
# one reference (truth model, rtol 1e-10, one core): thesis ~1 min, stress_rates_10 ~4 min.
EXPONENTIAL_REFERENCE_SCENES = ["thesis", "stress_rates_10"]
# The `long` scene's reference costs 20 min to 1.6 h of DOP853 on one core (1 s simulated:
# 1,163,308 steps of ~8.6e-7 s; 1,221 s on a quiet core, 5,820 s on a loaded one),
# so it is optional and off: with LONG_REFERENCE = [] the benchmark still times `long` and reports
# its E as "no reference"; set it to ["results/reference/long/truth.h5"] to judge E (measured with
# it: E ~5e-9 at long's tolerance 5e-7, docs/exponential.md Section 5).
LONG_REFERENCE = []


rule stability:
    input:
        scene_path("free_10s"),
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
    output:
        json="results/stability/stability.json",
        rk4_limit="results/figures/stability/rk4_limit.png",
        drift="results/figures/stability/energy_drift.png",
    log:
        "logs/bench/stability.log",
    benchmark:
        "results/benchmarks/rules/bench/stability.tsv"
    resources:
        # no record: estimate, 2 GB and 1 h (bisections and 10 s energy-drift runs per integrator)
        mem_mb=2000,
        runtime=60,
    params:
        code=code_hash("stability"),
        cfg=body_files_hash,  # the input files are checked against the config
    shell:
        "OMP_NUM_THREADS=1 MPLBACKEND=Agg {GIMBAL} stability --bodies {input.bodies} "
        "--reductions {input.reductions} --out-dir results/stability "
        "--figures-dir $(dirname {output.rk4_limit}) --config {CONFIG} > {log} 2>&1"


rule scaling:
    output:
        csv="results/benchmarks/scaling.csv",
        json="results/benchmarks/scaling.json",
        figure="results/figures/bench/scaling.png",
    log:
        "logs/bench/scaling.log",
    benchmark:
        "results/benchmarks/rules/bench/scaling.tsv"
    threads: TIMING_CORES  # alone (common.smk, TIMING_CORES)
    resources:
        **TIMING_RESOURCES,
        # no record: estimate, 2 GB (up to 8000 coordinates, dense baseline) and 1 h
        mem_mb=2000,
        runtime=60,
    params:
        code=code_hash("scaling"),
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg {GIMBAL} scaling --out-csv {output.csv} "
        "--out-json {output.json} --figure {output.figure} > {log} 2>&1"


rule pareto:
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        load_ranking="results/reduction/load/thesis.h5",
        # the converged DOP853 reference referees every error (the workflow's own truth is
        # the exponential integrator's)
        truth="results/reference/thesis/truth.h5",
    output:
        csv="results/benchmarks/pareto.csv",
        json="results/benchmarks/pareto.json",
        figure="results/figures/bench/pareto.png",
    log:
        "logs/bench/pareto.log",
    benchmark:
        "results/benchmarks/rules/bench/pareto.tsv"
    threads: TIMING_CORES  # alone (common.smk, TIMING_CORES)
    resources:
        **TIMING_RESOURCES,
        # no record: ~2 min per model and ~5 min for the truth (comment above): 13 min, so 30 min
        mem_mb=mem_mb(780.5),
        runtime=30,
    params:
        models=" ".join(f"'{m}'" for m in PARETO_MODELS),
        code=code_hash("pareto"),
        cfg=body_files_hash,  # the input files are checked against the config
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg {GIMBAL} pareto --scene thesis --truth {input.truth} "
        "--models {params.models} --repeats 5 --budget 600 --bodies {input.bodies} --reductions {input.reductions} "
        "--load-ranking {input.load_ranking} "
        "--out-csv {output.csv} --figure {output.figure} --config {CONFIG} > {log} 2>&1"


rule selection:
    input:
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        truth="results/sim/thesis/truth.h5",
        ranking="results/reduction/load/thesis.h5",
        cases=expand("results/sim/thesis/{model}.h5", model=SELECTION_MODELS),
    output:
        table="results/tables/selection.csv",
        figure="results/figures/bench/global_ranking.png",
    log:
        "logs/bench/selection.log",
    benchmark:
        "results/benchmarks/rules/bench/selection.tsv"
    resources:
        # no record: reads simulation files (as error_tables, error_tables_long.tsv 2.7 s, 159.3 MB)
        mem_mb=mem_mb(159.3),
        runtime=runtime_min(2.7),
    params:
        code=code_hash("selection"),
        cfg=body_files_hash,  # the input files are checked against the config
    shell:
        "MPLBACKEND=Agg {GIMBAL} selection --truth {input.truth} --cases {input.cases} "
        "--ranking {input.ranking} --reductions {input.reductions} --table {output.table} "
        "--figure {output.figure} --config {CONFIG} > {log} 2>&1"


rule reference_simulation:
    """The converged reference of a scene: DOP853 at rtol 1e-10 on the scene's truth model (the
    simulation default is the exponential integrator, so results/sim/{scene}/truth.h5 is not it).
    """
    input:
        model="results/models/{scene}/truth.h5",
    output:
        "results/reference/{scene}/truth.h5",
    log:
        "logs/reference/{scene}.log",
    benchmark:
        "results/benchmarks/rules/reference/{scene}.tsv"
    resources:
        # records: reference/stress_rates_100.tsv 367.8 s, reference/stress_lock.tsv 248.8 MB (max of
        # 6); the long scene has no record: ~1 h of DOP853 (LONG_REFERENCE above), so 2 h
        mem_mb=mem_mb(248.8),
        runtime=lambda wildcards: (
            120 if wildcards.scene == "long" else runtime_min(367.8)
        ),
    params:
        physics=scene_physics_hash,
        scene=scene_file,
        code=code_hash("simulate"),
        cfg=body_files_hash,  # the model's body files are checked against the config
    message:
        "DOP853 reference of scene {wildcards.scene} at rtol 1e-10 (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} simulate --scene {params.scene} --model-file {input.model} "
        "--integrator dop853 --rtol 1e-10 --atol 1e-14 --config {CONFIG} --out {output} > {log} 2>&1"


rule exponential_bench:
    input:
        truth_model="results/models/thesis/truth.h5",
        references=expand(
            "results/reference/{scene}/truth.h5", scene=EXPONENTIAL_REFERENCE_SCENES
        ),
        long_reference=LONG_REFERENCE,
        models=expand("results/models/thesis/{model}.h5", model=EXPONENTIAL_MODELS),
    output:
        json="results/benchmarks/exponential.json",
        md="results/benchmarks/exponential.md",
        csv="results/benchmarks/exponential.csv",
    log:
        "logs/bench/exponential.log",
    benchmark:
        "results/benchmarks/rules/bench/exponential.tsv"
    threads: TIMING_CORES  # alone (common.smk, TIMING_CORES)
    resources:
        **TIMING_RESOURCES,
        # no record: ~3 + 2.5 + 1 min (comment above EXPONENTIAL_MODELS), so 15 min; memory as simulate
        mem_mb=mem_mb(780.5),
        runtime=15,
    params:
        references=reference_arguments,
        models=lambda wildcards, input: " ".join(f"'{f}'" for f in input.models),
        code=code_hash("bench-exponential"),
        cfg=body_files_hash,  # the input files are checked against the config
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 {GIMBAL} bench-exponential "
        "--truth-model {input.truth_model} --reference {params.references} --models {params.models} "
        "--repeats 5 --out-json {output.json} --out-md {output.md} --out-csv {output.csv} --config {CONFIG} "
        "> {log} 2>&1"


# Scenes on which the exponential integrator's accuracy is verified against a converged DOP853
# reference; references cost (one core): thesis ~1 min, free ~2, damped ~1,
# stress_lock ~1, stress_rates_10 ~4, stress_rates_100 ~10 (and long ~1 h, see LONG_REFERENCE).
ACCURACY_SCENES = [
    "thesis",
    "free",
    "damped",
    "stress_lock",
    "stress_rates_10",
    "stress_rates_100",
]


rule exponential_accuracy:
    input:
        truth_model="results/models/thesis/truth.h5",
        references=expand("results/reference/{scene}/truth.h5", scene=ACCURACY_SCENES),
        long_reference=LONG_REFERENCE,
    output:
        json="results/verification/exponential.json",
        md="results/verification/exponential.md",
    log:
        "logs/bench/exponential_accuracy.log",
    benchmark:
        "results/benchmarks/rules/bench/exponential_accuracy.tsv"
    resources:
        # no record: one exponential run per accuracy scene (seconds each): as simulate
        mem_mb=mem_mb(780.5),
        runtime=runtime_min(301.6),
    params:
        references=reference_arguments,
        tol=cfgmod.value(config, "simulation.tolerance"),
        code=code_hash("exponential-accuracy"),
        cfg=body_files_hash,  # the input files are checked against the config
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} exponential-accuracy --truth-model {input.truth_model} "
        "--reference {params.references} --tol {params.tol} --out-json {output.json} "
        "--out-md {output.md} --config {CONFIG} > {log} 2>&1"


# The study's thesis table with both integrators: the thesis's own cases (the RK4 runs are
# ~2.5 min; the exponential integrator's ~5 s)
INTEGRATOR_TABLE_MODELS = importlib.import_module(
    "gimbal_reduction.results.study.cases"
).study_models(extended=False)


rule integrator_tables:
    """The study's error table with the exponential integrator against RK4: every
    study model and the truth integrated both ways, in one process (gimbal_reduction.results.bench.integrator_tables).
    """
    input:
        truth_model="results/models/thesis/truth.h5",
        models=expand("results/models/thesis/{model}.h5", model=INTEGRATOR_TABLE_MODELS),
    output:
        json="results/benchmarks/integrator_tables.json",
        csv="results/benchmarks/integrator_tables.csv",
        # the truth's RK4 run (half the limit), for other checks of the same setting to read
        truth_rk4="results/benchmarks/integrator_tables/truth_rk4.h5",
    log:
        "logs/results/integrator_tables.log",
    benchmark:
        "results/benchmarks/rules/integrator_tables.tsv"
    resources:
        # no record: the RK4 runs ~2.5 min (comment above), so 10 min; memory as simulate
        mem_mb=mem_mb(780.5),
        runtime=10,
    params:
        code=code_hash("integrator-tables"),
        cfg=body_files_hash,  # the input files are checked against the config
        physics=lambda wildcards: scenes_mod.load_scene(
            scene_path("thesis")
        ).config_hash(),
        tol=cfgmod.value(config, "simulation.tolerance"),
        models=lambda wildcards, input: " ".join(f"'{f}'" for f in input.models),
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} integrator-tables --scene config/scenes/thesis.yaml "
        "--truth-model {input.truth_model} --models {params.models} --tol {params.tol} "
        "--out-json {output.json} --out-csv {output.csv} --truth-rk4-out {output.truth_rk4} "
        "--config {CONFIG} > {log} 2>&1"


# Accuracy on request: tol-EPS on every study scene and the fast-spinning one, measured
# against the truth; the cheapest freq-, xmx- and global-N of the study tables at each EPS timed in
# the same run. `long` and `spin` are outside the frozen chain's validity, so there tol-EPS is a
# verified search (gimbal_reduction/reduction/verified_search.py: ~10 simulations per request, shared by the EPS).
TOLERANCE_TABLE_SCENES = list(
    importlib.import_module("gimbal_reduction.results.study.cases").STUDY_SCENES
)
# spin (config/scenes/spin.yaml): the case at a constant 10 rev/s, large gimbal motion; no study table
TOLERANCE_SCENES = TOLERANCE_TABLE_SCENES + ["spin"]
TOLERANCE_EPS = [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]


rule tolerance:
    input:
        scenes=[scene_path(s) for s in TOLERANCE_SCENES],
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        load_rankings=expand(
            "results/reduction/load/{scene}.h5", scene=TOLERANCE_SCENES
        ),
        tables=expand(
            "results/tables/{scene}/errors_ranking.csv", scene=TOLERANCE_TABLE_SCENES
        ),
        kernels=ancient(KERNELS),
    output:
        csv="results/benchmarks/tolerance.csv",
        json="results/benchmarks/tolerance.json",
        figure="results/figures/bench/tolerance.png",
        figure_pdf="results/figures/bench/tolerance.pdf",
    log:
        "logs/bench/tolerance.log",
    benchmark:
        "results/benchmarks/rules/bench/tolerance.tsv"
    threads: TIMING_CORES  # alone (common.smk, TIMING_CORES)
    resources:
        **TIMING_RESOURCES,
        # no record (run outside Snakemake): the same command run directly in this session on a
        # loaded 2-core machine, /usr/bin/time -v: 1147 s wall, 1035.4 MB peak (long's and spin's
        # verified searches 2/3 of it)
        mem_mb=mem_mb(1035.4),
        runtime=runtime_min(1147.0),
    params:
        eps=" ".join(f"{e:g}" for e in TOLERANCE_EPS),
        code=code_hash("tolerance"),
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg {GIMBAL} tolerance "
        "--scenes {input.scenes} --eps {params.eps} --modes-dir results/modes "
        "--reduction-dir results/reduction --tables-dir results/tables --repeats 5 "
        "--budget 60 --out-csv {output.csv} --out-json {output.json} --figure {output.figure} "
        "> {log} 2>&1"


rule bench:
    input:
        rules.reduction_benchmark.output,
        rules.stability.output,
        rules.scaling.output,
        rules.pareto.output,
        rules.selection.output,
        rules.exponential_bench.output,
        rules.exponential_accuracy.output,
        rules.tolerance.output,


# ---- `all`'s versions of the checks above (results/all/, the same path below it): every one, each
# cheap enough for the main job; `verify` and `bench` make the extended versions at the paths above,
# which the reports show instead where they exist (with their date; results.smk, REPORT_OPTIONAL).
# Converged references by the faster route: the exponential integrator on the truth at the scene's
# tolerance / ALL_REFERENCE_FACTOR (seconds a scene; `long` too), each checked against the converged
# DOP853 reference of the short scene ALL_ANCHOR_SCENES (rule reference_simulation, ~1 min of one
# core) by exponential_accuracy_all (--anchor: E <= 1e-9). The DOP853 reference of thesis also
# referees the Pareto benchmark, as in `bench`.
ALL_REFERENCE_FACTOR = 100  # as gimbal_reduction.results.bench.exponential_accuracy.EXPONENTIAL_REFERENCE_FACTOR
# Scenes whose reference runs at another Adams order than the default 4. At 5e-9 the local error of
# `long` is set by the unresolved ringing of the fast modes in g, which a higher-order extrapolation
# amplifies (docs/exponential.md Section 5): order 2 takes 144,938 steps where 4 takes 476,521 (48
# against ~71 CPU-s); the two references differ by E 2.1e-11. Thesis keeps 4: its reference is the
# second method of dynamics_verification_all (E <= 1e-10 against DOP853: 1.6e-11 at order 4, 1.2e-10
# at 2); the other scenes gain < 25 % from order 2. exponential_accuracy_all checks that route on
# thesis against DOP853 too (--anchor-orders: E <= 1e-9).
ALL_REFERENCE_ORDERS = {"long": 2}
ALL_ANCHOR_SCENES = ["thesis"]
ALL_ACCURACY_SCENES = ACCURACY_SCENES + ["long"]
ALL_EXPONENTIAL_SCENES = ["thesis", "stress_rates_10", "long"]
# Scenes whose run at their own tolerance exponential_accuracy_all reads from the study (one truth
# simulation per scene: results/study/{scene}/sim/truth.h5) instead of integrating it again
ALL_ACCURACY_STUDY_SCENES = [
    s
    for s in ALL_ACCURACY_SCENES
    if s in importlib.import_module("gimbal_reduction.results.study.cases").STUDY_SCENES
]
# ALL_CASE_BUDGET_S (common.smk): the timing repeats of `all`'s benchmarks


rule reference_exponential:
    """The converged reference of a scene by the faster route: the exponential integrator on the
    scene's truth model at its tolerance / ALL_REFERENCE_FACTOR, at the order ALL_REFERENCE_ORDERS
    gives (else the default).  No energy history (--no-energy): its consumers read the rates and the
    attitude; on long it cost 16 s of right-hand sides.
    """
    input:
        model="results/models/{scene}/truth.h5",
        kernels=ancient(KERNELS),
    output:
        "results/all/reference/{scene}/truth.h5",
    log:
        "logs/all/reference/{scene}.log",
    benchmark:
        "results/benchmarks/rules/all/reference/{scene}.tsv"
    resources:
        # as simulate (records: sim/thesis/truth.tsv 301.6 s, 780.5 MB)
        mem_mb=mem_mb(780.5),
        runtime=runtime_min(301.6),
    params:
        physics=scene_physics_hash,
        scene=scene_file,
        code=code_hash("simulate"),
        cfg=body_files_hash,
        order=lambda wildcards: (
            f"--order {ALL_REFERENCE_ORDERS[wildcards.scene]}"
            if wildcards.scene in ALL_REFERENCE_ORDERS
            else ""
        ),
        tol=lambda wildcards: repr(
            dag_scene(wildcards.scene).tighter_tolerance(
                cfgmod.value(config, "simulation.tolerance")
            )
            / ALL_REFERENCE_FACTOR
        ),
    message:
        "Converged reference of scene {wildcards.scene}: the exponential integrator at tol/100 (~50 CPU-s on long; log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} simulate --scene {params.scene} --model-file {input.model} "
        "--integrator exponential --tol {params.tol} {params.order} --no-energy --config {CONFIG} --out {output} > {log} 2>&1"


rule exponential_accuracy_all:
    input:
        truth_model="results/models/thesis/truth.h5",
        references=expand(
            "results/all/reference/{scene}/truth.h5", scene=ALL_ACCURACY_SCENES
        ),
        anchors=expand("results/reference/{scene}/truth.h5", scene=ALL_ANCHOR_SCENES),
        runs=expand(
            "results/study/{scene}/sim/truth.h5", scene=ALL_ACCURACY_STUDY_SCENES
        ),
    output:
        json="results/all/verification/exponential.json",
        md="results/all/verification/exponential.md",
    log:
        "logs/all/exponential_accuracy.log",
    benchmark:
        "results/benchmarks/rules/all/exponential_accuracy.tsv"
    resources:
        mem_mb=mem_mb(780.5),
        runtime=runtime_min(301.6),
    params:
        references=lambda wildcards, input: scene_file_arguments(input.references),
        anchors=lambda wildcards, input: scene_file_arguments(input.anchors),
        # the Adams orders of the references (long's 2): that route is checked against DOP853 too
        anchor_orders=" ".join(
            str(o) for o in sorted(set(ALL_REFERENCE_ORDERS.values()))
        ),
        runs=lambda wildcards, input: " ".join(
            f"'{s}={f}'" for s, f in zip(ALL_ACCURACY_STUDY_SCENES, input.runs)
        ),
        tol=cfgmod.value(config, "simulation.tolerance"),
        code=code_hash("exponential-accuracy"),
        cfg=body_files_hash,
    message:
        "The exponential integrator against its converged references on every scene, the study's truths read (~1 CPU-minute; log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} exponential-accuracy --truth-model {input.truth_model} "
        "--reference {params.references} --anchor {params.anchors} --anchor-orders {params.anchor_orders} "
        "--runs {params.runs} --tol {params.tol} "
        "--out-json {output.json} --out-md {output.md} --config {CONFIG} > {log} 2>&1"


rule exponential_bench_all:
    input:
        truth_model="results/models/thesis/truth.h5",
        references=expand(
            "results/all/reference/{scene}/truth.h5", scene=ALL_EXPONENTIAL_SCENES
        ),
        models=expand("results/models/thesis/{model}.h5", model=EXPONENTIAL_MODELS),
        # the truth's untimed DOP853 run at rtol 1e-6 (E, steps) and the reference of its E
        dop853_untimed="results/all/benchmarks/pareto_errors.csv",
        dop853_reference="results/reference/thesis/truth.h5",
        # long's truth case is not run here: its 5 whole runs timed alone by the runtime job, its E
        # and steps from the study's run (gimbal_reduction.results.bench.exponential.case_from_runs)
        long_runtime="results/benchmarks/runtime/long.json",
        long_truth="results/study/long/sim/truth.h5",
    output:
        json="results/all/benchmarks/exponential.json",
        md="results/all/benchmarks/exponential.md",
        csv="results/all/benchmarks/exponential.csv",
    log:
        "logs/all/bench_exponential.log",
    benchmark:
        "results/benchmarks/rules/all/exponential.tsv"
    threads: TIMING_CORES
    resources:
        **TIMING_RESOURCES,
        mem_mb=mem_mb(780.5),
        runtime=15,
    params:
        references=lambda wildcards, input: scene_file_arguments(input.references),
        models=lambda wildcards, input: " ".join(f"'{f}'" for f in input.models),
        # s a case: stress_rates_10's 5 runs (~3 s) fit; DOP853 (~22 s a whole run) is timed over a
        # prefix (5 runs of ~0.8 s) and scaled by the steps of pareto_errors_all's untimed whole
        # run, whose E it takes
        budget=4.0,
        code=code_hash("bench-exponential"),
        cfg=body_files_hash,
    message:
        "Exponential integrator benchmark: medians of repeated runs, alone on the machine (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 {GIMBAL} bench-exponential "
        "--truth-model {input.truth_model} --reference {params.references} --models {params.models} "
        "--repeats 5 --budget {params.budget} --dop853-untimed {input.dop853_untimed} {input.dop853_reference} "
        "--truth-runs long {input.long_runtime} {input.long_truth} "
        "--out-json {output.json} --out-md {output.md} "
        "--out-csv {output.csv} --config {CONFIG} > {log} 2>&1"


# Pareto in `all`: two of `bench`'s reduced models (a reduced model's E is the model's, the same to 3
# digits with every integrator, so two show it) and the truth with every integrator, DOP853 at rtol
# 1e-6 (1e-8 in `bench`; its 1e-10 is the reference itself). Two jobs: the untimed runs (E, steps) beside the others, then
# the timing alone, each setting's 5 runs within ALL_CASE_BUDGET_S (a slower one timed over a prefix
# of the scene and scaled by its steps, gimbal_reduction/results/bench/timing.py); the dense
# baseline over 0.1 ms (0.2 in `bench`)
ALL_PARETO_MODELS = ["load-10", "global-100"]
# generalised-alpha at one step: `bench`'s 1e-5 and 5e-6 s exceed thesis's output interval (2.5e-6 s),
# which caps the step (integrators._generalized_alpha), so all three are the same run
ALL_PARETO_GALPHA_STEPS = [2.5e-6]


rule pareto_errors_all:
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        load_ranking="results/reduction/load/thesis.h5",
        truth="results/reference/thesis/truth.h5",
        kernels=ancient(KERNELS),
        # the truth's RK4 run at half the limit (setting rk4-0.5), made by integrator_tables_all
        truth_rk4="results/all/benchmarks/integrator_tables/truth_rk4.h5",
    output:
        "results/all/benchmarks/pareto_errors.csv",
    log:
        "logs/all/pareto_errors.log",
    benchmark:
        "results/benchmarks/rules/all/pareto_errors.tsv"
    resources:
        mem_mb=mem_mb(780.5),
        runtime=30,
    params:
        models=" ".join(f"'{m}'" for m in ALL_PARETO_MODELS),
        galpha_steps=" ".join(f"{h:g}" for h in ALL_PARETO_GALPHA_STEPS),
        code=code_hash("pareto"),
        cfg=body_files_hash,
    message:
        "Pareto front, untimed part: each model and integrator's error against the reference (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} pareto --scene thesis --truth {input.truth} "
        "--models {params.models} --errors-only --rtols 1e-6 --galpha-steps {params.galpha_steps} "
        "--truth-runs 'rk4-0.5={input.truth_rk4}' "
        "--bodies {input.bodies} --reductions {input.reductions} --load-ranking {input.load_ranking} "
        "--out-csv {output} --config {CONFIG} > {log} 2>&1"


rule pareto_all:
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        load_ranking="results/reduction/load/thesis.h5",
        truth="results/reference/thesis/truth.h5",
        errors="results/all/benchmarks/pareto_errors.csv",
    output:
        csv="results/all/benchmarks/pareto.csv",
        json="results/all/benchmarks/pareto.json",
        figure="results/all/figures/bench/pareto.png",
    log:
        "logs/all/pareto.log",
    benchmark:
        "results/benchmarks/rules/all/pareto.tsv"
    threads: TIMING_CORES
    resources:
        **TIMING_RESOURCES,
        mem_mb=mem_mb(780.5),
        runtime=30,
    params:
        models=" ".join(f"'{m}'" for m in ALL_PARETO_MODELS),
        galpha_steps=" ".join(f"{h:g}" for h in ALL_PARETO_GALPHA_STEPS),
        budget=ALL_CASE_BUDGET_S,
        code=code_hash("pareto"),
        cfg=body_files_hash,
    message:
        "Pareto front, timed part: medians of repeated runs, alone on the machine (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg {GIMBAL} pareto --scene thesis --truth {input.truth} "
        "--models {params.models} --repeats 5 --budget {params.budget} --rtols 1e-6 --galpha-steps {params.galpha_steps} "
        "--errors-from {input.errors} --dense-duration 1e-4 "
        "--bodies {input.bodies} --reductions {input.reductions} --load-ranking {input.load_ranking} "
        "--out-csv {output.csv} --figure {output.figure} --config {CONFIG} > {log} 2>&1"


rule scaling_all:
    output:
        csv="results/all/benchmarks/scaling.csv",
        json="results/all/benchmarks/scaling.json",
        figure="results/all/figures/bench/scaling.png",
    log:
        "logs/all/scaling.log",
    benchmark:
        "results/benchmarks/rules/all/scaling.tsv"
    threads: TIMING_CORES
    resources:
        **TIMING_RESOURCES,
        mem_mb=2000,
        runtime=10,
    params:
        code=code_hash("scaling"),
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg {GIMBAL} scaling --quick --out-csv {output.csv} "
        "--out-json {output.json} --figure {output.figure} > {log} 2>&1"


rule stability_all:
    input:
        scene_path("free_10s"),
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
    output:
        json="results/all/stability/stability.json",
        rk4_limit="results/all/figures/stability/rk4_limit.png",
        drift="results/all/figures/stability/energy_drift.png",
    log:
        "logs/all/stability.log",
    benchmark:
        "results/benchmarks/rules/all/stability.tsv"
    resources:
        mem_mb=2000,
        runtime=30,
    params:
        code=code_hash("stability"),
        cfg=body_files_hash,
    message:
        "Stability stress tests: RK4's step limit and the energy drift over 1 s (~20 CPU s with RK4's kernels compiled; log: {log})"
    shell:
        "OMP_NUM_THREADS=1 MPLBACKEND=Agg {GIMBAL} stability --quick --bodies {input.bodies} "
        "--reductions {input.reductions} --out-dir $(dirname {output.json}) "
        "--figures-dir $(dirname {output.rk4_limit}) --config {CONFIG} > {log} 2>&1"


# Selection in `all`: the study's own simulations of thesis (its truth and every study model of the
# families compared), no simulation of its own
ALL_SELECTION_MODELS = [
    m
    for m in SELECTION_MODELS
    if m
    in importlib.import_module("gimbal_reduction.results.study.cases").study_models()
]


rule selection_all:
    input:
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        truth="results/study/thesis/sim/truth.h5",
        ranking="results/reduction/load/thesis.h5",
        cases=expand("results/study/thesis/sim/{model}.h5", model=ALL_SELECTION_MODELS),
    output:
        table="results/all/tables/selection.csv",
        figure="results/all/figures/bench/global_ranking.png",
    log:
        "logs/all/selection.log",
    benchmark:
        "results/benchmarks/rules/all/selection.tsv"
    resources:
        mem_mb=mem_mb(159.3),
        runtime=runtime_min(2.7),
    params:
        code=code_hash("selection"),
        cfg=body_files_hash,
    shell:
        "MPLBACKEND=Agg {GIMBAL} selection --truth {input.truth} --cases {input.cases} "
        "--ranking {input.ranking} --reductions {input.reductions} --table {output.table} "
        "--figure {output.figure} --config {CONFIG} > {log} 2>&1"


# The integrator table in `all`: the study's key models (one per family) and the truth, both ways
ALL_INTEGRATOR_TABLE_MODELS = [
    m
    for m in importlib.import_module("gimbal_reduction.results.study.cases").KEY_MODELS
    if m in INTEGRATOR_TABLE_MODELS
]


use rule integrator_tables as integrator_tables_all with:
    input:
        truth_model="results/models/thesis/truth.h5",
        models=expand(
            "results/models/thesis/{model}.h5", model=ALL_INTEGRATOR_TABLE_MODELS
        ),
    output:
        json="results/all/benchmarks/integrator_tables.json",
        csv="results/all/benchmarks/integrator_tables.csv",
        truth_rk4="results/all/benchmarks/integrator_tables/truth_rk4.h5",
    log:
        "logs/all/integrator_tables.log",
    benchmark:
        "results/benchmarks/rules/all/integrator_tables.tsv"


# Accuracy on request in `all`: every scene of `tolerance`, two of its EPS, each verdict with its case
# (measured at these EPS): at 1e-2 the frozen chain's estimate holds and long's and spin's searches stop at
# the rigid model; at 1e-6 the estimate misses on thesis (measured 1.4e-6), the search's first guess
# misses on spin and meets on long (`bench` asks all of TOLERANCE_EPS; 1e-4 would cost ~50 CPU s more:
# long's search simulates 4 candidates).
# Two jobs: the requests reduced (long's and spin's verified searches) and every model run once for its
# E, beside the others (~50 CPU s), its model files kept; then their timing alone, each model's 5 runs
# within ALL_CASE_BUDGET_S (a slower one whole as often as fits: common.smk)
ALL_TOLERANCE_EPS = [1e-2, 1e-6]


rule tolerance_untimed_all:
    input:
        scenes=[scene_path(s) for s in TOLERANCE_SCENES],
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        load_rankings=expand(
            "results/reduction/load/{scene}.h5", scene=TOLERANCE_SCENES
        ),
        tables=expand(
            "results/tables/{scene}/errors_ranking.csv", scene=TOLERANCE_TABLE_SCENES
        ),
        kernels=ancient(KERNELS),
        # the study's truth of each study scene, read rather than integrated again
        truths=expand(
            "results/study/{scene}/sim/truth.h5", scene=TOLERANCE_TABLE_SCENES
        ),
    output:
        csv="results/all/benchmarks/tolerance_untimed.csv",
        json="results/all/benchmarks/tolerance_untimed.json",
        models=directory("results/all/benchmarks/tolerance_models"),
        figure="results/all/figures/bench/tolerance.png",
        figure_pdf="results/all/figures/bench/tolerance.pdf",
    log:
        "logs/all/tolerance_untimed.log",
    benchmark:
        "results/benchmarks/rules/all/tolerance_untimed.tsv"
    resources:
        mem_mb=mem_mb(1035.4),
        runtime=runtime_min(1147.0),
    params:
        eps=" ".join(f"{e:g}" for e in ALL_TOLERANCE_EPS),
        truths=lambda wildcards, input: " ".join(
            f"'{s}={f}'" for s, f in zip(TOLERANCE_TABLE_SCENES, input.truths)
        ),
        code=code_hash("tolerance"),
    message:
        "Accuracy on request, untimed part: the smallest model per error target and scene, the study's truths read (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 MPLBACKEND=Agg {GIMBAL} tolerance --untimed --keep-models {output.models} "
        "--scenes {input.scenes} --truths {params.truths} --eps {params.eps} --modes-dir results/modes "
        "--reduction-dir results/reduction --tables-dir results/tables "
        "--out-csv {output.csv} --out-json {output.json} --figure {output.figure} > {log} 2>&1"


rule tolerance_all:
    input:
        scenes=[scene_path(s) for s in TOLERANCE_SCENES],
        untimed="results/all/benchmarks/tolerance_untimed.json",
        models="results/all/benchmarks/tolerance_models",
        # the truth of each study scene timed by the runtime job (5 whole runs, alone), not again
        runtimes=expand(
            "results/benchmarks/runtime/{scene}.json", scene=TOLERANCE_TABLE_SCENES
        ),
    output:
        csv="results/all/benchmarks/tolerance.csv",
        json="results/all/benchmarks/tolerance.json",
    log:
        "logs/all/tolerance.log",
    benchmark:
        "results/benchmarks/rules/all/tolerance.tsv"
    threads: TIMING_CORES
    resources:
        **TIMING_RESOURCES,
        mem_mb=mem_mb(1035.4),
        runtime=10,
    params:
        budget=ALL_CASE_BUDGET_S,
        truth_times=lambda wildcards, input: " ".join(
            f"'{s}={f}'" for s, f in zip(TOLERANCE_TABLE_SCENES, input.runtimes)
        ),
        code=code_hash("tolerance"),
    message:
        "Accuracy on request, timed part: medians of repeated runs, alone on the machine (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 {GIMBAL} tolerance --scenes {input.scenes} "
        "--times-from {input.untimed} --models-from {input.models} --truth-times {params.truth_times} --repeats 5 "
        "--budget {params.budget} --out-csv {output.csv} --out-json {output.json} > {log} 2>&1"

# Stage 5: the study on every study scene (gimbal_reduction.results.study.cases.STUDY_SCENES: thesis, damped, smooth,
# long), its error tables, findings, figures and PDF reports (one per scene, and the study's).
#   snakemake --cores 2 study     every scene's simulations
#   snakemake --cores 2 report    the study PDF and one PDF per scene
# Every check is an input of the reports in `all`'s version; the extended versions of `verify` and
# `bench` are shown instead where made (REPORT_OPTIONAL below).
# Lints left, justified in common.smk (above GIMBAL): the rules' shell commands use GIMBAL, CONFIG from outside
# the rule; no rule names a conda environment or container (the project's .venv).
_cases = importlib.import_module("gimbal_reduction.results.study.cases")
STUDY_SCENES = list(_cases.STUDY_SCENES)
STUDY_MODELS = _cases.study_models()
SCENE_MODELS = ["truth"] + STUDY_MODELS


rule study_scene:
    """Every study model of one scene, reduced and simulated in one process (gimbal_reduction.results.study.run_scene:
    the two stages of a per-model simulation, called in process; ~50 models in ~0.5 min).
    """
    input:
        scene=scene_file,
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        load_ranking="results/reduction/load/{scene}.h5",
        cb=expand("results/reduction/cb/body{n}.h5", n=RINGS),
        kernels=ancient(KERNELS),
    output:
        sims=[f"results/study/{{scene}}/sim/{m}.h5" for m in SCENE_MODELS],
        coupled="results/study/{scene}/coupled_modes.json",
        # every model's H-infinity and H2 error against the truth (gimbal_reduction.reduction.frequency_error)
        frequency="results/study/{scene}/frequency_error.json",
    log:
        "logs/study/{scene}.log",
    benchmark:
        "results/benchmarks/rules/study/{scene}.tsv"
    wildcard_constraints:
        scene="|".join(STUDY_SCENES),
    resources:
        # records: study/long.tsv 470.1 s (load 11 on 2 cores; 200.5 CPU s), 1395.4 MB (40001 samples)
        mem_mb=mem_mb(1395.4),
        runtime=runtime_min(470.1),
    params:
        physics=scene_physics_hash,
        code=code_hash("run-scene"),
        integrator=cfgmod.value(config, "simulation.integrator"),
        options=integrator_options,
        models=" ".join(f"'{m}'" for m in SCENE_MODELS),
        out_dir="results/study/{scene}/sim",
        # the body, reduction and ranking files are checked against the configuration (--config)
        cfg=body_files_hash,
    message:
        "Study of scene {wildcards.scene}: the truth and every study model simulated in one process (~1-3 CPU-minutes on long; log: {log})"
    shell:
        "OMP_NUM_THREADS=1 {GIMBAL} run-scene --scene {input.scene} --models {params.models} "
        "--bodies {input.bodies} --reductions {input.reductions} --load-ranking {input.load_ranking} "
        "--cb-bases {input.cb} --out-dir {params.out_dir} --coupled-modes {output.coupled} "
        "--frequency-error {output.frequency} --integrator {params.integrator} "
        "{params.options} --config {CONFIG} > {log} 2>&1"


rule study:
    input:
        [study_sims(s) for s in STUDY_SCENES],


rule error_tables:
    input:
        truth="results/study/{scene}/sim/truth.h5",
        cases=lambda wildcards: study_sims(wildcards.scene)[1:],
        frequency="results/study/{scene}/frequency_error.json",
    output:
        ranking=report(
            "results/tables/{scene}/errors_ranking.csv",
            category="Tables",
            subcategory="{scene}",
            caption="../report/table.rst",
        ),
        static=report(
            "results/tables/{scene}/errors_static.csv",
            category="Tables",
            subcategory="{scene}",
            caption="../report/table.rst",
        ),
        coordinates="results/tables/{scene}/coordinates.csv",
    log:
        "logs/results/error_tables_{scene}.log",
    benchmark:
        "results/benchmarks/rules/error_tables_{scene}.tsv"
    wildcard_constraints:
        scene="|".join(STUDY_SCENES),
    resources:
        # records: error_tables_long.tsv 2.7 s, 159.3 MB (max of 4)
        mem_mb=mem_mb(159.3),
        runtime=runtime_min(2.7),
    params:
        code=code_hash("tables"),
    shell:
        "{GIMBAL} tables --truth {input.truth} --cases {input.cases} "
        "--ranking-table {output.ranking} --static-table {output.static} "
        "--frequency-error {input.frequency} --coordinates-table {output.coordinates} > {log} 2>&1"


rule findings:
    input:
        ranking="results/tables/{scene}/errors_ranking.csv",
        static="results/tables/{scene}/errors_static.csv",
        reduction="results/verification/reduction.json",
    output:
        csv=report(
            "results/tables/{scene}/findings.csv",
            category="Findings",
            subcategory="{scene}",
            caption="../report/findings.rst",
        ),
        json="results/tables/{scene}/findings.json",
    log:
        "logs/results/findings_{scene}.log",
    benchmark:
        "results/benchmarks/rules/findings_{scene}.tsv"
    wildcard_constraints:
        scene="|".join(STUDY_SCENES),
    resources:
        # records: findings_damped.tsv 1.3 s, findings_long.tsv 71.7 MB (max of 4)
        mem_mb=mem_mb(71.7),
        runtime=runtime_min(1.3),
    params:
        code=code_hash("findings"),
    shell:
        "{GIMBAL} findings --ranking-table {input.ranking} --static-table {input.static} "
        "--reduction {input.reduction} --scene {wildcards.scene} --csv {output.csv} --json {output.json} "
        "> {log} 2>&1"


rule study_figures:
    input:
        truth="results/study/{scene}/sim/truth.h5",
        cases=lambda wildcards: expand(
            "results/study/{scene}/sim/{model}.h5",
            scene=wildcards.scene,
            model=_cases.rate_figure_models(wildcards.scene),
        ),
        ranking="results/tables/{scene}/errors_ranking.csv",
        static="results/tables/{scene}/errors_static.csv",
    output:
        manifest="results/figures/study/{scene}/figures.json",
        # the summary figures, for `snakemake --report` (the rate figures are in the scene's PDF)
        error_ranking=report(
            "results/figures/study/{scene}/error_ranking.pdf",
            category="Figures",
            subcategory="{scene}",
            caption="../report/error_ranking.rst",
        ),
        error_static=report(
            "results/figures/study/{scene}/error_static.pdf",
            category="Figures",
            subcategory="{scene}",
            caption="../report/error_static.rst",
        ),
        error_load_cases=report(
            "results/figures/study/{scene}/error_load_cases.pdf",
            category="Figures",
            subcategory="{scene}",
            caption="../report/error_load_cases.rst",
        ),
        runtime_error=report(
            "results/figures/study/{scene}/runtime_error.pdf",
            category="Figures",
            subcategory="{scene}",
            caption="../report/runtime_error.rst",
        ),
    log:
        "logs/results/figures_{scene}.log",
    benchmark:
        "results/benchmarks/rules/study_figures_{scene}.tsv"
    wildcard_constraints:
        scene="|".join(STUDY_SCENES),
    resources:
        # records: study_figures_thesis.tsv 180.3 s, 215.1 MB (max of 4)
        mem_mb=mem_mb(215.1),
        runtime=runtime_min(180.3),
    params:
        code=code_hash("figures"),
        out_dir="results/figures/study/{scene}",
    message:
        "Figures of scene {wildcards.scene}'s study (log: {log})"
    shell:
        "MPLBACKEND=Agg {GIMBAL} figures --truth {input.truth} --cases {input.cases} "
        "--ranking-table {input.ranking} --static-table {input.static} --out-dir {params.out_dir} "
        "> {log} 2>&1"


rule runtime:
    """A timing job: run and set-up times (medians of 5 runs in one process) of the models the
    scene's decision names, the rigid model and the truth (gimbal_reduction.results.bench.runtime).
    """
    input:
        scene=scene_file,
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        load_ranking="results/reduction/load/{scene}.h5",
        cb=expand("results/reduction/cb/body{n}.h5", n=RINGS),
        ranking="results/tables/{scene}/errors_ranking.csv",
        static="results/tables/{scene}/errors_static.csv",
        truth="results/study/{scene}/sim/truth.h5",
        truth_basis="results/verification/truth_basis.json",
        kernels=ancient(KERNELS),
    output:
        "results/benchmarks/runtime/{scene}.json",
    log:
        "logs/results/runtime_{scene}.log",
    benchmark:
        "results/benchmarks/rules/runtime_{scene}.tsv"
    wildcard_constraints:
        scene="|".join(STUDY_SCENES),
    threads: TIMING_CORES  # alone (common.smk, TIMING_CORES); BLAS pinned to one thread
    resources:
        **TIMING_RESOURCES,
        # no record: estimate, 5 repeats of ~5 models; long's truth ~8 s a run
        mem_mb=1000,
        runtime=10,
    params:
        # no --budget: the decision quotes these, each a median of 5 runs, long's truth too (~40 s)
        code=code_hash("runtime"),
        integrator=cfgmod.value(config, "simulation.integrator"),
        options=integrator_options,
        cfg=body_files_hash,
    message:
        "Run times of scene {wildcards.scene}'s decision models: medians of repeated runs, alone on the machine (log: {log})"
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 {GIMBAL} runtime --scene {input.scene} "
        "--bodies {input.bodies} --reductions {input.reductions} --load-ranking {input.load_ranking} "
        "--cb-bases {input.cb} --ranking-table {input.ranking} --static-table {input.static} --truth {input.truth} "
        "--truth-basis {input.truth_basis} --repeats 5 "
        "--integrator {params.integrator} {params.options} "
        "--config {CONFIG} --out {output} > {log} 2>&1"


rule decision:
    """The decision table: per scene and accuracy requirement, the cheapest model meeting it,
    its coordinates and measured times (gimbal_reduction.results.study.decision).
    """
    input:
        rankings=expand("results/tables/{scene}/errors_ranking.csv", scene=STUDY_SCENES),
        statics=expand("results/tables/{scene}/errors_static.csv", scene=STUDY_SCENES),
        truths=expand("results/study/{scene}/sim/truth.h5", scene=STUDY_SCENES),
        runtimes=expand("results/benchmarks/runtime/{scene}.json", scene=STUDY_SCENES),
        truth_basis="results/verification/truth_basis.json",
        sims=[f for s in STUDY_SCENES for f in study_sims(s)],
    output:
        json="results/tables/decision.json",
        csv="results/tables/decision.csv",
    log:
        "logs/results/decision.log",
    benchmark:
        "results/benchmarks/rules/decision.tsv"
    resources:
        mem_mb=300,
        runtime=2,
    params:
        code=code_hash("decision"),
        scenes=" ".join(STUDY_SCENES),
    shell:
        "{GIMBAL} decision --scenes {params.scenes} --ranking-tables {input.rankings} "
        "--static-tables {input.statics} --truths {input.truths} --runtimes {input.runtimes} "
        "--truth-basis {input.truth_basis} --sims {input.sims} --out-json {output.json} "
        "--out-csv {output.csv} > {log} 2>&1"


# What the reports show of the checks (verification, benchmarks): `all` builds each in its cheap version
# (results/all/..., all_version) as an input of the reports; a report shows the extended version that
# `verify` or `bench` made (the paths here) instead where it exists, with its date (shown_version).
REPORT_OPTIONAL = {
    "stability": "results/stability/stability.json",
    "pareto": "results/benchmarks/pareto.csv",
    "scaling": "results/benchmarks/scaling.json",
    "selection": "results/tables/selection.csv",
    "integrators": "results/benchmarks/integrator_tables.json",
    "dynamics": "results/verification/dynamics.json",
    "exponential": "results/verification/exponential.json",
    "exponential_bench": "results/benchmarks/exponential.json",
    "fe_full": "results/verification/fe.json",
}
REPORT_BENCH_FIGURES = [
    "results/figures/bench/pareto.png",
    "results/figures/bench/scaling.png",
    "results/figures/bench/global_ranking.png",
    "results/figures/stability/rk4_limit.png",
    "results/figures/stability/energy_drift.png",
]


rule report_scene:
    input:
        scene=scene_file,
        truth="results/study/{scene}/sim/truth.h5",
        ranking="results/tables/{scene}/errors_ranking.csv",
        static="results/tables/{scene}/errors_static.csv",
        findings="results/tables/{scene}/findings.json",
        figures="results/figures/study/{scene}/figures.json",
        fe="results/verification/fe_fast.json",
        modes="results/benchmarks/modes.json",
        reduction="results/verification/reduction.json",
        coupled="results/study/{scene}/coupled_modes.json",
        decision="results/tables/decision.json",
        # the run-time section's benchmark: `all`'s version (shown: `bench`'s where made)
        exponential_bench=all_version(REPORT_OPTIONAL["exponential_bench"]),
    output:
        report(
            "results/report/{scene}.pdf",
            category="Reports",
            subcategory="{scene}",
            caption="../report/scene_report.rst",
        ),
    log:
        "logs/results/report_{scene}.log",
    benchmark:
        "results/benchmarks/rules/report_{scene}.tsv"
    wildcard_constraints:
        scene="|".join(STUDY_SCENES),
    resources:
        # records: report_thesis.tsv 3.4 s, 376.1 MB (max of 4)
        mem_mb=mem_mb(376.1),
        runtime=runtime_min(3.4),
    params:
        code=code_hash("scene-report"),
        cfg=config_hash(),  # the report prints the config's values (the file given by --configfile)
        exponential_bench=lambda wildcards: shown_version(
            REPORT_OPTIONAL["exponential_bench"]
        ),
    shell:
        "{GIMBAL} scene-report --ranking-table {input.ranking} --static-table {input.static} "
        "--findings {input.findings} --figures {input.figures} --fe {input.fe} "
        "--modes-benchmark {input.modes} --reduction {input.reduction} --truth {input.truth} "
        "--config {CONFIG} --scene {input.scene} --mode-shapes --bench-figures "
        "--coupled-modes {input.coupled} --decision {input.decision} --part scene "
        "--exponential-bench {params.exponential_bench} "
        "--out {output} > {log} 2>&1"


rule model_report:
    """What does not depend on the scene, once: geometry, FE checks, mode shapes and static modes,
    the mode selection, the coupled modes (at the thesis scene's initial state) and the benchmarks
    of `bench` if present (gimbal_reduction.results.study.report --part model).
    """
    input:
        scene=scene_path("thesis"),
        mode_shapes=expand("results/figures/mode_shapes_body{n}.json", n=BODIES),
        fe="results/verification/fe_fast.json",
        modes="results/benchmarks/modes.json",
        reduction="results/verification/reduction.json",
        coupled="results/study/thesis/coupled_modes.json",
        checks=[
            all_version(p) for p in [*REPORT_OPTIONAL.values(), *REPORT_BENCH_FIGURES]
        ],
        extended=extended_report_inputs,
    output:
        report(
            "results/report/model.pdf",
            category="Reports",
            caption="../report/scene_report.rst",
        ),
    log:
        "logs/results/report_model.log",
    benchmark:
        "results/benchmarks/rules/report_model.tsv"
    resources:
        mem_mb=mem_mb(376.1),
        runtime=runtime_min(3.4),
    params:
        code=code_hash("scene-report"),
        cfg=config_hash(),
        optional=optional_report_inputs,
        bench_figures=report_bench_figures,
    shell:
        "{GIMBAL} scene-report --part model --fe {input.fe} --modes-benchmark {input.modes} "
        "--reduction {input.reduction} --config {CONFIG} --scene {input.scene} "
        "--mode-shapes {input.mode_shapes} --coupled-modes {input.coupled} {params.optional} "
        "--bench-figures {params.bench_figures} --out {output} > {log} 2>&1"


rule report:
    input:
        expand("results/report/{scene}.pdf", scene=STUDY_SCENES),
        "results/report/model.pdf",
        "results/report/report.pdf",


rule study_report:
    """The study's PDF: every finding on every scene with its verdict and numbers, the truth's own
    error, the discussion and the recommendation (gimbal_reduction.results.study.study_report).
    """
    input:
        rankings=expand("results/tables/{scene}/errors_ranking.csv", scene=STUDY_SCENES),
        statics=expand("results/tables/{scene}/errors_static.csv", scene=STUDY_SCENES),
        findings=expand("results/tables/{scene}/findings.json", scene=STUDY_SCENES),
        figures=expand("results/figures/study/{scene}/figures.json", scene=STUDY_SCENES),
        scenes=[scene_path(s) for s in STUDY_SCENES],
        fe="results/verification/fe_fast.json",
        reduction="results/verification/reduction.json",
        mode_ranking="results/tables/ranking.csv",
        truth_basis="results/verification/truth_basis.json",
        decision="results/tables/decision.json",
        checks=[
            all_version(p)
            for p in [*REPORT_OPTIONAL.values(), "results/benchmarks/tolerance.json"]
        ],
        extended=lambda wildcards: [
            p
            for p in [*REPORT_OPTIONAL.values(), "results/benchmarks/tolerance.json"]
            if os.path.exists(p)
        ],
    output:
        report(
            "results/report/report.pdf",
            category="Reports",
            caption="../report/study_report.rst",
        ),
    log:
        "logs/results/study_report.log",
    benchmark:
        "results/benchmarks/rules/study_report.tsv"
    resources:
        # records: study_report.tsv 1.5 s, 142.7 MB
        mem_mb=mem_mb(142.7),
        runtime=runtime_min(1.5),
    params:
        code=code_hash("study-report"),
        optional=lambda wildcards: f"{optional_report_inputs(wildcards)} --tolerance "
        f"{shown_version(rules.tolerance.output.json)}",
    shell:
        "{GIMBAL} study-report --scenes {input.scenes} --ranking-tables {input.rankings} "
        "--static-tables {input.statics} --findings {input.findings} --figures {input.figures} "
        "--fe {input.fe} --reduction {input.reduction} --mode-ranking {input.mode_ranking} --truth-basis {input.truth_basis} "
        "--decision {input.decision} {params.optional} "
        "--out {output} > {log} 2>&1"


# ---- The longest scene first. After the kernels' compilation the study's critical path is the chain
# of its longest scene: `long` (1 s simulated against 15 ms) takes ~10 s of load-aware ranking, then
# ~2 min of study_scene, then figures and report, while each other scene's chain takes ~30 s. The
# scheduler starts ready jobs by priority (the rules' measured times to the run's end, workflow/
# priorities.json), and a priority belongs to a rule, not to a wildcard value: so the longest scene has
# its own copies of the two rules on that path, with its name as their only scene (ruleorder: they, not
# the general rules, make its files), and a priority of their own. Measured on a clean clone's `all`:
# with one priority for every scene the scheduler left `long`'s chain to the end.
FIRST_SCENE = max(STUDY_SCENES, key=lambda name: dag_scene(name).duration)


use rule load_ranking as load_ranking_first with:
    wildcard_constraints:
        scene=FIRST_SCENE,


use rule study_scene as study_scene_first with:
    wildcard_constraints:
        scene=FIRST_SCENE,


ruleorder: load_ranking_first > load_ranking
ruleorder: study_scene_first > study_scene

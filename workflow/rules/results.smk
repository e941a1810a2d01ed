# Stage 5: the thesis study on the `thesis` scene, error tables, findings, figures and the PDF report.
STUDY_MODELS = importlib.import_module("results.study.cases").study_models()
STUDY_SIMS = expand("results/sim/thesis/{model}.h5", model=STUDY_MODELS)
TRUTH = "results/sim/thesis/truth.h5"


rule integrator_tables:
    """The study's error table with the exponential integrator against RK4 (issue 13): every
    study model and the truth integrated both ways, in one process (results.bench.integrator_tables)."""
    input:
        truth_model="results/models/thesis/truth.h5",
        models=expand("results/models/thesis/{model}.h5", model=STUDY_MODELS),
    output:
        json="results/benchmarks/integrator_tables.json",
        csv="results/benchmarks/integrator_tables.csv",
    params:
        code=code_hash("results.bench.integrator_tables"),
        physics=lambda wildcards: scenes_mod.load_scene("config/scenes/thesis.yaml").config_hash(),
        tol=cfgmod.value(config, "simulation.tolerance"),
        models=lambda wildcards, input: " ".join(f"'{f}'" for f in input.models),
    log:
        "logs/results/integrator_tables.log",
    benchmark:
        "results/benchmarks/rules/integrator_tables.tsv"
    shell:
        "OMP_NUM_THREADS=1 {PY} -m results.bench.integrator_tables --scene config/scenes/thesis.yaml "
        "--truth-model {input.truth_model} --models {params.models} --tol {params.tol} "
        "--out-json {output.json} --out-csv {output.csv} > {log} 2>&1"


rule study:
    input:
        TRUTH,
        STUDY_SIMS,


rule error_tables:
    input:
        truth=TRUTH,
        cases=STUDY_SIMS,
    output:
        ranking="results/tables/errors_ranking.csv",
        static="results/tables/errors_static.csv",
    params:
        code=code_hash("results.study.tables"),
    log:
        "logs/results/error_tables.log",
    benchmark:
        "results/benchmarks/rules/error_tables.tsv"
    shell:
        "{PY} -m results.study.tables --truth {input.truth} --cases {input.cases} "
        "--ranking-table {output.ranking} --static-table {output.static} > {log} 2>&1"


rule findings:
    input:
        ranking="results/tables/errors_ranking.csv",
        static="results/tables/errors_static.csv",
        reduction="results/verification/reduction.json",
    output:
        csv="results/tables/findings.csv",
        json="results/tables/findings.json",
    params:
        code=code_hash("results.study.findings"),
    log:
        "logs/results/findings.log",
    benchmark:
        "results/benchmarks/rules/findings.tsv"
    shell:
        "{PY} -m results.study.findings --ranking-table {input.ranking} --static-table {input.static} "
        "--reduction {input.reduction} --csv {output.csv} --json {output.json} > {log} 2>&1"


rule study_figures:
    input:
        truth=TRUTH,
        cases=STUDY_SIMS,
        ranking="results/tables/errors_ranking.csv",
        static="results/tables/errors_static.csv",
    output:
        "results/figures/study/figures.json",
    params:
        code=code_hash("results.study.figures"),
    log:
        "logs/results/figures.log",
    benchmark:
        "results/benchmarks/rules/study_figures.tsv"
    shell:
        "MPLBACKEND=Agg {PY} -m results.study.figures --truth {input.truth} --cases {input.cases} "
        "--ranking-table {input.ranking} --static-table {input.static} --out-dir results/figures/study "
        "> {log} 2>&1"


rule report:
    input:
        scene="config/scenes/thesis.yaml",
        mode_shapes=rules.mode_shapes.input,
        truth=TRUTH,
        ranking="results/tables/errors_ranking.csv",
        static="results/tables/errors_static.csv",
        findings="results/tables/findings.json",
        figures="results/figures/study/figures.json",
        fe="results/verification/fe.json",
        modes="results/benchmarks/modes.json",
        reduction="results/verification/reduction.json",
        stability="results/stability/stability.json",
        pareto="results/benchmarks/pareto.csv",
        scaling="results/benchmarks/scaling.json",
        selection="results/tables/selection.csv",
        integrators="results/benchmarks/integrator_tables.json",
        bench_figures=[rules.pareto.output.figure, rules.scaling.output.figure, rules.selection.output.figure,
                       rules.stability.output.rk4_limit, rules.stability.output.drift],
    output:
        "results/report/report.pdf",
    params:
        code=code_hash("results.study.report"),
        cfg=config_hash(),   # the report prints the config's values (the file given by --configfile)
    log:
        "logs/results/report.log",
    benchmark:
        "results/benchmarks/rules/report.tsv"
    shell:
        "{PY} -m results.study.report --ranking-table {input.ranking} --static-table {input.static} "
        "--findings {input.findings} --figures {input.figures} --fe {input.fe} "
        "--modes-benchmark {input.modes} --reduction {input.reduction} --truth {input.truth} "
        "--config {CONFIG} --scene {input.scene} --mode-shapes {input.mode_shapes} "
        "--stability {input.stability} --pareto {input.pareto} --scaling {input.scaling} "
        "--selection {input.selection} --integrators {input.integrators} "
        "--bench-figures {input.bench_figures} "
        "--out {output} > {log} 2>&1"

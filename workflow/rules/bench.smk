# Stage 6: fast and stable (issue 6). Run time against error, the right-hand side's cost
# against model size (with the dense-mass-matrix baseline timed in the same run), and the
# stability stress tests. Every benchmark writes files; nothing here is a timed assertion.
#   snakemake --cores 2 bench
# Pareto: one model per family at ~40-100 elastic coordinates (each costs ~2 min of repeated
# runs; the truth, always added, ~5 min).
PARETO_MODELS = ["freq-10", "xmx-10", "load-10", "global-100"]
# Load-aware and global selection against frequency / XMX / XMGMX at equal coordinate counts
SELECTION_MODELS = (["rigid"] + [f"{f}-{n}" for f in ("freq", "xmx", "xmgmx") for n in (5, 10, 15, 20, 25)]
                    + [f"load-{n}" for n in (5, 10, 15, 20, 25, 30, 40)]
                    + [f"global-{n}" for n in (20, 40, 60, 80, 100, 120, 160)])


rule stability:
    input:
        "config/scenes/free_10s.yaml",
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
    output:
        json="results/stability/stability.json",
        rk4_limit="results/figures/stability/rk4_limit.png",
        drift="results/figures/stability/energy_drift.png",
    params:
        code=code_hash("results.bench.stability"),
    log:
        "logs/bench/stability.log",
    benchmark:
        "results/benchmarks/rules/bench/stability.tsv"
    shell:
        "OMP_NUM_THREADS=1 MPLBACKEND=Agg {PY} -m results.bench.stability --bodies {input.bodies} "
        "--reductions {input.reductions} --out-dir results/stability "
        "--figures-dir $(dirname {output.rk4_limit}) > {log} 2>&1"


rule scaling:
    output:
        csv="results/benchmarks/scaling.csv",
        json="results/benchmarks/scaling.json",
        figure="results/figures/bench/scaling.png",
    params:
        code=code_hash("results.bench.scaling"),
    log:
        "logs/bench/scaling.log",
    benchmark:
        "results/benchmarks/rules/bench/scaling.tsv"
    # both cores, so that no other job runs beside the timed runs; BLAS pinned to one thread
    # all the same (Snakemake sets OPENBLAS_NUM_THREADS to the job's threads): one core each side
    threads: 2
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg {PY} -m results.bench.scaling --out-csv {output.csv} "
        "--out-json {output.json} --figure {output.figure} > {log} 2>&1"


rule pareto:
    input:
        bodies=expand("results/modes/body{n}.h5", n=BODIES),
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        load_ranking="results/reduction/load/thesis.h5",
        truth="results/sim/thesis/truth.h5",
    output:
        csv="results/benchmarks/pareto.csv",
        json="results/benchmarks/pareto.json",
        figure="results/figures/bench/pareto.png",
    params:
        models=" ".join(f"'{m}'" for m in PARETO_MODELS),
        code=code_hash("results.bench.pareto"),
    log:
        "logs/bench/pareto.log",
    benchmark:
        "results/benchmarks/rules/bench/pareto.tsv"
    # both cores, so that no other job runs beside the timed runs; BLAS pinned to one thread
    # all the same (Snakemake sets OPENBLAS_NUM_THREADS to the job's threads): one core each side
    threads: 2
    shell:
        "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MPLBACKEND=Agg {PY} -m results.bench.pareto --scene thesis --truth {input.truth} "
        "--models {params.models} --repeats 5 --budget 600 --bodies {input.bodies} --reductions {input.reductions} "
        "--load-ranking {input.load_ranking} "
        "--out-csv {output.csv} --figure {output.figure} > {log} 2>&1"


rule selection:
    input:
        reductions=expand("results/reduction/body{n}.h5", n=BODIES),
        truth="results/sim/thesis/truth.h5",
        ranking="results/reduction/load/thesis.h5",
        cases=expand("results/sim/thesis/{model}.h5", model=SELECTION_MODELS),
    output:
        table="results/tables/selection.csv",
        figure="results/figures/bench/global_ranking.png",
    params:
        code=code_hash("results.bench.selection"),
    log:
        "logs/bench/selection.log",
    benchmark:
        "results/benchmarks/rules/bench/selection.tsv"
    shell:
        "MPLBACKEND=Agg {PY} -m results.bench.selection --truth {input.truth} --cases {input.cases} "
        "--ranking {input.ranking} --reductions {input.reductions} --table {output.table} "
        "--figure {output.figure} > {log} 2>&1"


rule bench:
    input:
        rules.stability.output,
        rules.scaling.output,
        rules.pareto.output,
        rules.selection.output,

# The gimbal study as a Snakemake workflow (8.20.5, pinned in the venv; README): stages are wired
# here, the work is done by the importable packages gimbal_reduction/geometry/, gimbal_reduction/solver/, gimbal_reduction/reduction/, results/.
# Every job reruns when the code its stage runs or the config values it reads change
# (params.code and params.cfg, workflow/rules/common.smk).
#   snakemake --cores 2 all        everything that exists so far
#   snakemake --cores 2 mesh       gmsh meshes of the four bodies
#   snakemake --cores 2 modes      100 supported modes per body
#   snakemake --cores 2 verify_fe  finite-element verification (results/verification/fe.json)
#   snakemake --cores 2 reduction  momentum coefficients, rankings, static modes per body
#   snakemake --cores 2 results/sim/thesis/freq-10.h5   any scene and reduced model, on request
#   snakemake --cores 2 study      every study scene (thesis, damped, smooth, long): truth + every case
#   snakemake --cores 2 report     error tables, findings, figures; results/report/{scene}.pdf, report.pdf
#   snakemake --cores 2 verify     the extended checks: FE on the finest meshes, the DOP853 references of
#                                  every verified scene, the study's whole integrator table
#   snakemake --cores 2 bench      the extended benchmarks: every Pareto setting, the full size sweep, 10 s
#                                  stability runs, every tolerance request
# `all` is the study and its reports with every check in a version cheap enough for it (results/all/,
# bench.smk and verification.smk say how each is made cheaper); a report shows the extended version
# of `verify` or `bench` instead where it exists, with its date.
configfile: "config/config.yaml"


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/geometry.smk"
include: "workflow/rules/modes.smk"
include: "workflow/rules/verification.smk"
include: "workflow/rules/reduction.smk"
include: "workflow/rules/models.smk"
include: "workflow/rules/dynamics.smk"
include: "workflow/rules/bench.smk"
include: "workflow/rules/bench_models.smk"
include: "workflow/rules/results.smk"
include: "workflow/rules/outputs.smk"


rule verify:
    input:
        "results/verification/fe.json",
        "results/verification/dynamics.json",
        "results/verification/exponential.json",
        "results/benchmarks/integrator_tables.json",


rule all:
    default_target: True
    input:
        rules.modes.input,
        rules.mode_shapes.input,
        "results/benchmarks/modes.json",
        "results/verification/fe_fast.json",
        rules.reduction.input,
        rules.reduction_report.output,
        rules.report.input,


# Scheduling: every rule's priority is its measured time to the end of a clean `all` (workflow/
# priorities.json, measured by `make benchmark-all`), so that of the ready jobs the ones with the most
# work still behind them start first (gimbal_reduction/workflow/schedule.py says why and how much).
_schedule = importlib.import_module("gimbal_reduction.workflow.schedule")
_schedule.apply(
    workflow.rules,
    _schedule.read_priorities(Path(workflow.basedir) / "workflow" / "priorities.json"),
)

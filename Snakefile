# The gimbal study as a Snakemake workflow (8.20.5, pinned in the venv; README): stages are wired
# here, the work is done by the importable packages geometry/, solver/, reduction/, results/.
# Every job reruns when the code its stage runs or the config values it reads change
# (params.code and params.cfg, workflow/rules/common.smk).
#   snakemake --cores 2 all        everything that exists so far
#   snakemake --cores 2 mesh       gmsh meshes of the four bodies
#   snakemake --cores 2 modes      100 supported modes per body
#   snakemake --cores 2 verify_fe  finite-element verification (results/verification/fe.json)
#   snakemake --cores 2 reduction  momentum coefficients, rankings, static modes per body
#   snakemake --cores 2 results/sim/thesis/freq-10.h5   any scene and reduced model, on request
#   snakemake --cores 2 study      the thesis study: truth + every reduced case on the thesis scene
#   snakemake --cores 2 report     error tables, findings, figures and results/report/report.pdf
#   snakemake --cores 2 bench      run time vs error (Pareto), RHS cost vs size, stability stress tests
configfile: "config/config.yaml"


include: "workflow/rules/common.smk"
include: "workflow/rules/geometry.smk"
include: "workflow/rules/modes.smk"
include: "workflow/rules/verification.smk"
include: "workflow/rules/reduction.smk"
include: "workflow/rules/models.smk"
include: "workflow/rules/dynamics.smk"
include: "workflow/rules/bench.smk"
include: "workflow/rules/results.smk"


rule all:
    input:
        rules.modes.input,
        rules.mode_shapes.input,
        "results/benchmarks/modes.json",
        "results/verification/fe.json",
        rules.reduction.input,
        rules.reduction_report.output,
        rules.dynamics.input,
        "results/report/report.pdf",
    default_target: True

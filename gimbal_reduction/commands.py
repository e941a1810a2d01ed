"""The ``gimbal`` command: every stage of the pipeline as a subcommand.

``gimbal STAGE [ARGS...]`` runs the stage's own command line (``gimbal STAGE --help`` shows it);
``gimbal`` alone lists the stages.  The Snakemake rules call the stages exactly this way, so a
job's shell command is what a user types to redo it by hand:

    gimbal mesh --body 2 --out results/mesh/body2.msh --meta results/mesh/body2.json --config config/config.yaml
    gimbal simulate --scene thesis --model-file results/models/thesis/freq-10.h5 --out freq-10.h5

This module owns the stage vocabulary: the name of each stage and the module that runs it.  A
stage's module is imported only when that stage runs, so ``gimbal simulate`` never loads DOLFINx.
"""
from __future__ import annotations

import importlib
import sys

# stage -> (module below gimbal_reduction, what it does), in pipeline order
STAGES: dict[str, tuple[str, str]] = {
    "mesh": ("gimbal_reduction.geometry.mesh", "Gmsh mesh of one body"),
    "modes": ("gimbal_reduction.solver.fe.modes", "the supported modes of one body (DOLFINx shells/solid, SLEPc)"),
    "fe-verify": ("gimbal_reduction.solver.fe.verify", "finite-element checks against independent references"),
    "reduce": ("gimbal_reduction.reduction.stage", "momentum coefficients, rankings and static modes of one body"),
    "reduction-report": ("gimbal_reduction.reduction.report", "the reduction's tables and figures"),
    "load-ranking": ("gimbal_reduction.reduction.load_aware", "the load-aware ranking of a scene"),
    "model": ("gimbal_reduction.reduction.models", "one reduced model of a scene"),
    "warmup": ("gimbal_reduction.solver.dynamics.warmup", "compile the dynamics kernels into Numba's cache"),
    "simulate": ("gimbal_reduction.solver.dynamics.simulate", "integrate one reduced model through one scene"),
    "export": ("gimbal_reduction.solver.dynamics.export", "a reduced model's linearised state space for control design"),
    "run-scene": ("gimbal_reduction.results.study.run_scene", "every case of one study scene, in one process"),
    "cases": ("gimbal_reduction.results.study.cases", "the study's cases of a scene"),
    "tables": ("gimbal_reduction.results.study.tables", "a scene's error tables"),
    "findings": ("gimbal_reduction.results.study.findings", "the thesis's findings, checked on a scene"),
    "figures": ("gimbal_reduction.results.study.figures", "a scene's figures"),
    "mode-shapes": ("gimbal_reduction.results.study.mode_shapes", "print-ready mode shapes and the mode-shape VTU"),
    "scene-report": ("gimbal_reduction.results.study.report", "one scene's report PDF"),
    "study-report": ("gimbal_reduction.results.study.study_report", "the study report PDF"),
    "bench-summary": ("gimbal_reduction.results.bench.summary", "summaries of the stages' run-time records"),
    "verify-dynamics": ("gimbal_reduction.results.bench.verify_dynamics", "the dynamics against its JAX oracle"),
    "exponential-accuracy": ("gimbal_reduction.results.bench.exponential_accuracy",
                             "the exponential integrator against converged DOP853"),
    "integrator-tables": ("gimbal_reduction.results.bench.integrator_tables", "integrator comparison tables"),
    "bench-exponential": ("gimbal_reduction.results.bench.exponential", "the exponential integrator's benchmark"),
    "pareto": ("gimbal_reduction.results.bench.pareto", "run time against error, with its Pareto front"),
    "scaling": ("gimbal_reduction.results.bench.scaling", "right-hand-side cost against size"),
    "stability": ("gimbal_reduction.results.bench.stability", "numerical stability stress tests"),
    "tolerance": ("gimbal_reduction.results.bench.tolerance", "tol-EPS requests checked against the truth"),
    "selection": ("gimbal_reduction.results.bench.selection", "mode selections at equal coordinates"),
    "truth-basis": ("gimbal_reduction.results.bench.truth_basis", "the truth's own error, by a larger basis"),
}


def module_of(stage: str) -> str:
    """The full module name that runs ``stage`` (KeyError if there is no such stage)."""
    return f"{__package__ or 'gimbal_reduction'}.{STAGES[stage][0]}"


def usage() -> str:
    width = max(map(len, STAGES))
    rows = "\n".join(f"  {name:<{width}}  {what}" for name, (_, what) in STAGES.items())
    return f"usage: gimbal STAGE [ARGS...]   (gimbal STAGE --help)\n\nstages:\n{rows}"


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(usage())
        return 0 if argv else 2
    stage, rest = argv[0], argv[1:]
    if stage not in STAGES:
        print(f"gimbal: no stage {stage!r}; the stages are {', '.join(STAGES)}", file=sys.stderr)
        return 2
    return importlib.import_module(module_of(stage)).main(rest) or 0


if __name__ == "__main__":
    sys.exit(main())

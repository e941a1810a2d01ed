"""The ``gimbal`` command: every stage of the pipeline as a subcommand.

``gimbal STAGE [ARGS...]`` runs the stage's own command line (``gimbal STAGE --help`` shows it);
``gimbal`` alone lists the stages.  The Snakemake rules call the stages exactly this way, so a
job's shell command is what a user types to redo it by hand:

    gimbal mesh --body 2 --out results/mesh/body2.msh --meta results/mesh/body2.json --config config/config.yaml
    gimbal simulate --scene thesis --model-file results/models/thesis/freq-10.h5 --out freq-10.h5

This module owns the stage vocabulary: the name of each stage and the module that runs it.  A
stage's module is imported only when that stage runs, so ``gimbal simulate`` never loads DOLFINx.

Before it imports the stage, ``gimbal`` runs the BLAS and OpenMP pools on one thread
(``SINGLE_THREADED``, unless the caller set them), as every rule of the workflow does: a sum's
order depends on the thread count, so a result at round-off level (a tol-EPS search judging E
near its floor) would otherwise differ between a laptop and the workflow.
"""
from __future__ import annotations

import importlib
import os
import sys

# stage -> (module below gimbal_reduction, what it does), in pipeline order
STAGES: dict[str, tuple[str, str]] = {
    "mesh": ("geometry.mesh", "Gmsh mesh of one body"),
    "modes": ("solver.fe.modes", "the supported modes of one body (DOLFINx shells/solid, SLEPc)"),
    "fe-verify": ("solver.fe.verify", "finite-element checks against independent references"),
    "reduce": ("reduction.stage", "momentum coefficients, rankings and static modes of one body"),
    "reduction-report": ("reduction.report", "the reduction's tables and figures"),
    "load-ranking": ("reduction.load_aware", "the load-aware ranking of a scene"),
    "model": ("reduction.models", "one reduced model of a scene"),
    "warmup": ("solver.dynamics.warmup", "compile the dynamics kernels into Numba's cache"),
    "simulate": ("solver.dynamics.simulate", "integrate one reduced model through one scene"),
    "export": ("solver.dynamics.export", "a reduced model's linearised state space for control design"),
    "paraview": ("results.paraview", "the deformed bodies over time, for ParaView (PVD of VTU frames)"),
    "render": ("results.render", "one frame of a ParaView series or a VTU, to PNG"),
    "run-scene": ("results.study.run_scene", "every case of one study scene, in one process"),
    "cases": ("results.study.cases", "the study's cases of a scene"),
    "tables": ("results.study.tables", "a scene's error tables"),
    "findings": ("results.study.findings", "the thesis's findings, checked on a scene"),
    "figures": ("results.study.figures", "a scene's figures"),
    "mode-shapes": ("results.study.mode_shapes", "print-ready mode shapes and the mode-shape VTU"),
    "scene-report": ("results.study.report", "one scene's report PDF"),
    "study-report": ("results.study.study_report", "the study report PDF"),
    "bench-summary": ("results.bench.summary", "summaries of the stages' run-time records"),
    "verify-dynamics": ("results.bench.verify_dynamics", "the dynamics against its JAX oracle"),
    "exponential-accuracy": ("results.bench.exponential_accuracy",
                             "the exponential integrator against converged DOP853"),
    "integrator-tables": ("results.bench.integrator_tables", "integrator comparison tables"),
    "bench-exponential": ("results.bench.exponential", "the exponential integrator's benchmark"),
    "pareto": ("results.bench.pareto", "run time against error, with its Pareto front"),
    "scaling": ("results.bench.scaling", "right-hand-side cost against size"),
    "stability": ("results.bench.stability", "numerical stability stress tests"),
    "tolerance": ("results.bench.tolerance", "tol-EPS requests checked against the truth"),
    "selection": ("results.bench.selection", "mode selections at equal coordinates"),
    "truth-basis": ("results.bench.truth_basis", "the truth's own error, by a larger basis"),
}


# the thread-count variables the numerical libraries read when they load (OpenBLAS, OpenMP, MKL)
SINGLE_THREADED = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def single_threaded(environ) -> None:
    """Set ``SINGLE_THREADED`` in ``environ`` where the caller has not set a value."""
    for key, value in SINGLE_THREADED.items():
        environ.setdefault(key, value)


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
    single_threaded(os.environ)          # before the stage loads NumPy's BLAS
    return importlib.import_module(module_of(stage)).main(rest) or 0


if __name__ == "__main__":
    sys.exit(main())

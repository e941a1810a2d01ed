"""The few calls a notebook makes: build a reduced model, simulate a scene, read results.

Everything here is a thin, documented front of the stages the workflow runs; the workflow's
files are the same files these calls read and write.  Units: inch, lbf, second, radian.

    from gimbal_reduction import api

    model = api.reduce("freq-10", "thesis", bodies="results/modes", reductions="results/reduction")
    run = api.simulate(model, "thesis")                 # the modal exponential integrator
    truth = api.read_simulation("results/study/thesis/sim/truth.h5")
    api.error(truth, run)                               # eq. 3.53 per gimbal rate, dimensionless

A reduced model's coordinates: 4 gimbal angles, then each body's kept elastic coordinates
(``model.chain.n_modes`` per body, bodies 2..5).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gimbal_reduction.reduction import models, names
from gimbal_reduction.solver.bodydata import BODIES
from gimbal_reduction.solver.dynamics import chainfile, error_measure, multibody, scenes, simfile
from gimbal_reduction.solver.dynamics import simulate as simulate_stage
from gimbal_reduction.workflow import config as cfgmod


@dataclass(frozen=True)
class ReducedModel:
    """A reduced model of the chain: ``chain`` (solver.dynamics.multibody.Chain), its ``name``
    (grammar: gimbal_reduction.reduction.models), and the attributes its file carries."""

    name: str
    chain: object
    attrs: dict = field(default_factory=dict)

    @property
    def n_elastic(self) -> int:
        """Kept elastic coordinates over all bodies."""
        return int(sum(self.chain.n_modes))


@dataclass(frozen=True)
class Simulation:
    """One run through a scene, at its output samples: t (T,) [s], gamma (T, 4) [rad],
    gamma_dot (T, 4) [rad/s], platform_attitude (T, 3, 3) (the platform's frame in case axes),
    the integrator's figures in ``stats`` (steps, wall times [s], ...); from ``simulate``
    also every coordinate y (T, n) and rate y' (T, n) (4 gimbal angles, then each body's
    kept elastic coordinates) and the energy {kinetic, potential, input_work} (T,) [in lbf]."""

    model: str
    scene: str
    t: np.ndarray
    gamma: np.ndarray
    gamma_dot: np.ndarray
    platform_attitude: np.ndarray | None
    stats: dict = field(default_factory=dict)
    y: np.ndarray | None = None
    yd: np.ndarray | None = None
    energy: dict | None = None


def _files(folder_or_files, what: str) -> dict[int, str]:
    """{body: path} from a folder holding body{n}.h5, or from four paths (bodies 2..5)."""
    if isinstance(folder_or_files, (str, os.PathLike)):
        return {b: str(Path(folder_or_files) / f"body{b}.h5") for b in BODIES}
    paths = list(folder_or_files)
    if len(paths) != len(BODIES):
        raise ValueError(f"{what}: give a folder or {len(BODIES)} paths (bodies 2..5), got {len(paths)}")
    return dict(zip(BODIES, map(str, paths)))


def reduce(name: str, scene, bodies="results/modes", reductions="results/reduction",
           load_ranking=None, config="config/config.yaml", runs=None) -> ReducedModel:
    """Reduced model ``name`` (``freq-10``, ``xmx-10``, ``static-8``, ``tol-1e-4``, ...) on a scene
    (a name of config/scenes or a path), from the modal stage's body files and, for the ranked
    families, the reduction stage's files (a folder, or four paths for bodies 2..5).  ``config``:
    the configuration the body files must have been made from (None skips that check).  ``runs``:
    a ``gimbal_reduction.reduction.verified_search.Runs`` to keep a tol- request's verified-search
    simulations for the next request on the same scene (None: not kept)."""
    scene = scenes.load_scene(scene) if isinstance(scene, (str, os.PathLike)) else scene
    cfg = cfgmod.load_config(config) if config is not None else None
    chain, spec, attrs = models.reduce_model(
        name, scene, _files(bodies, "bodies"),
        _files(reductions, "reductions") if names.needs_reduction_rankings(name) else None,
        load_ranking, config=cfg, runs=runs)
    return ReducedModel(spec.name, chain, attrs)


def read_model(path) -> ReducedModel:
    """A reduced-model file (results/models/{scene}/{model}.h5) as a ReducedModel."""
    chain, info = chainfile.read_chain(str(path))
    return ReducedModel(str(info.get("model", Path(path).stem)), chain, dict(info))


def simulate(model: ReducedModel, scene, integrator: str = "exponential", **options) -> Simulation:
    """Integrate ``model`` through ``scene`` (name or path): the modal exponential integrator by
    default; ``integrator`` "rk4", "dop853" or "generalized-alpha" for another, ``options`` its
    own (tol, step, ...).  The scene's damping is applied to the model's modes."""
    scene = scenes.load_scene(scene) if isinstance(scene, (str, os.PathLike)) else scene
    chain = model.chain
    if scene.damping_ratio:
        chain = multibody.with_damping(chain, scene.damping_ratio)
    step = options.pop("step", None)
    run, problem = simulate_stage.run_scene(chain, scene, integrator=integrator, step=step,
                                            model_name=model.name, **options)
    attitude = simulate_stage.platform_attitude(chain, run)
    stats = {"steps": run.steps, "step": run.step, "integration_time_s": run.wall_time,
             "method": run.method, **dict(run.stats)}
    kinetic, potential, work = simulate_stage.energy_history(problem, run)
    y, yd = np.asarray(run.y), np.asarray(run.yd)
    return Simulation(model.name, scene.name, np.asarray(run.t), y[:, :4], yd[:, :4], attitude, stats,
                      y, yd, {"kinetic": kinetic, "potential": potential, "input_work": work})


def read_simulation(path) -> Simulation:
    """A simulation file (results/sim/{scene}/{model}.h5, results/study/{scene}/sim/...)."""
    data = simfile.read_sim(str(path))
    attrs = data["attrs"]
    return Simulation(data["model"], str(attrs.get("scene", "")), data["t"], data["gamma"],
                      data["gamma_dot"], data["platform_attitude"], attrs, energy=data.get("energy"))


def error(truth: Simulation, case: Simulation) -> np.ndarray:
    """E of eq. 3.53 per gimbal rate (4,), dimensionless: int e^2 dt / int r^2 dt on the common
    output grid (error_measure)."""
    error_measure.check_same_grid(truth.t, case.t, case.model)
    return error_measure.error_measure(truth.t, truth.gamma_dot, case.gamma_dot)


def attitude_error_arcsec(truth: Simulation, case: Simulation) -> np.ndarray:
    """The angle between the two runs' platform attitudes (T,) [arcsec]."""
    error_measure.check_same_grid(truth.t, case.t, case.model)
    return error_measure.attitude_error(truth.platform_attitude, case.platform_attitude) \
        * error_measure.ARCSEC_PER_RAD

"""The RK4 stability limit with modal damping: derived from the damped linearised chain's
eigenvalues on RK4's region (integrators.rk4_damped_limit), checked against the limit measured
by running RK4 on a synthetic chain, and enforced by simulate with a message naming damping."""
import numpy as np
import pytest

from gimbal_reduction.results.bench.oracle import synthetic_chain
from gimbal_reduction.solver.dynamics import integrators, linearized, simulate
from gimbal_reduction.solver.dynamics.problem import Problem

from .conftest import write_scene

MODEL = ("models", "scene", "xmx-2.h5")


def test_ray_radius_matches_the_region():
    # undamped (imaginary axis): the project's 2.785; real axis: 2.785; zeta = 0.5: 2.6225
    assert integrators.rk4_ray_radius(1j)[0] == pytest.approx(2.785)
    assert integrators.rk4_ray_radius(-1.0)[0] == pytest.approx(2.785, abs=1e-3)
    d = -0.5 + 1j * np.sqrt(0.75)
    r = integrators.rk4_ray_radius(d)[0]
    assert r == pytest.approx(2.6225, abs=1e-3)
    assert abs(integrators.rk4_amplification(r * 1.001 * d)) > 1 > abs(integrators.rk4_amplification(r * 0.999 * d))


def stable(prob, h, steps=2000):
    prob.omega_max = 1e-12                    # the guard off: measure, do not refuse
    prob._damped_spectrum = np.zeros(0, complex)
    try:
        integrators.integrate(prob, steps * h, h, method="rk4", step=h)
    except integrators.DivergenceError:
        return False
    return True


def test_damped_limit_matches_the_measured_limit():
    chain, _ = synthetic_chain(seed=2, damping_ratio=0.5)
    y0 = np.zeros(chain.n_coordinates)
    yd0 = np.zeros(chain.n_coordinates)
    yd0[4:] = 1e-6                                    # a small elastic motion: the linear regime
    lam = linearized.coupled_damped_eigenvalues(chain, y0)
    derived = integrators.rk4_damped_limit(lam)
    prob = Problem(chain, y0=y0, yd0=yd0)
    undamped = integrators.rk4_stability_limit(linearized.coupled_omega_max(chain, y0))
    assert derived < 0.97 * undamped                   # damping makes the explicit limit smaller
    assert stable(prob, 0.98 * derived)
    assert not stable(prob, 1.03 * derived)            # measured limit within 3 % of the derived one
    assert not stable(prob, 0.99 * undamped)           # the undamped limit was unsafe


def test_simulate_refuses_a_step_beyond_the_damped_limit(work, refused):
    scene = write_scene(work / "damped.yaml", damping_ratio=0.5)
    from gimbal_reduction.solver.dynamics import chainfile, scenes
    sc = scenes.load_scene(str(scene))
    chain, _ = chainfile.read_chain(work.joinpath(*MODEL), sc.damping_ratio)
    prob = simulate.scene_problem(chain, sc)
    damped, undamped = integrators.rk4_limit(prob), integrators.rk4_stability_limit(prob.omega_max)
    assert damped < undamped
    step = 0.5 * (damped + undamped)
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL), "--out",
                            work / "out" / "s.h5", "--integrator", "rk4", "--step", repr(step)],
            ("stability limit", "damping"), work / "out")

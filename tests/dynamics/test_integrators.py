"""Verification of the chain dynamics on small synthetic bodies (no JAX needed).

Each check is a pure function of gimbal_reduction.solver.dynamics.checks returning
check records {name, value, tolerance, passed}; the tests assert them.
"""

import numpy as np
import pytest

from gimbal_reduction.solver.dynamics.error_measure import error_measure
from gimbal_reduction.solver.dynamics import checks as dc
from gimbal_reduction.solver.dynamics import integrators, linearized, multibody
from gimbal_reduction.solver.dynamics.problem import Problem, make_rhs
from gimbal_reduction.results.bench.oracle import synthetic_chain

try:
    from gimbal_reduction.solver.dynamics import compiled  # noqa: F401
    HAS_NUMBA = True
except ImportError:
    HAS_NUMBA = False
# long runs need the compiled right-hand side (the NumPy path is ~100x slower)
needs_numba = pytest.mark.skipif(not HAS_NUMBA, reason="numba not installed (workflow/envs/install.sh)")


def assert_checks(results):
    if isinstance(results, dict):
        results = [results]
    for r in results:
        assert r["passed"], f"{r['name']}: {r['value']:.3e} (tolerance {r['tolerance']:.1e})"


def free_state(chain, rates=(0.3, -0.2, 0.25, 0.15)):
    n = chain.n_coordinates
    y0 = np.zeros(n)
    y0[:4] = [0.1, -np.pi / 2 + 0.2, -0.3, 0.4]
    yd0 = np.zeros(n)
    yd0[:4] = rates
    return y0, yd0


def test_compiled_rhs_matches_reference():
    chain, _ = synthetic_chain(seed=4, damping_ratio=0.01)
    rng = np.random.default_rng(1)
    n = chain.n_coordinates
    case = multibody.CaseMotion(amplitude=(1.0, 0.3, -0.2), frequency=(2.0, 1.0, 0.0),
                                omega0=(0.1, 0.0, 0.2))
    torque = np.array([0.1, 0.0, -0.2, 0.05])
    fast = make_rhs(chain, case, torque, fast=True)
    ref = make_rhs(chain, case, torque, fast=False)
    for _ in range(3):
        y = np.concatenate([rng.uniform(-3, 3, 4), 0.02 * rng.normal(size=n - 4)])
        yd = rng.normal(size=n)
        a, b = fast(0.3, y, yd), ref(0.3, y, yd)
        assert dc.relative_difference(a, b) < 1e-12


def test_articulated_body_solve_matches_dense_solve():
    chain, _ = synthetic_chain(seed=5)
    rng = np.random.default_rng(2)
    n = chain.n_coordinates
    y = np.concatenate([rng.uniform(-3, 3, 4), 0.02 * rng.normal(size=n - 4)])
    assert_checks(dc.solve_consistency("synthetic", chain, y, rng.normal(size=n)))
    # with a modified modal diagonal (implicit integrator's iteration matrix)
    d = 1.0 + rng.uniform(0, 10, n - 4)
    M = multibody.mass_matrix(chain, y) + np.diag(np.concatenate([np.zeros(4), d - 1]))
    r = rng.normal(size=n)
    assert dc.relative_difference(multibody.solve_mass(chain, y, r, d), np.linalg.solve(M, r)) < 1e-11


@needs_numba
def test_free_scene_conserves_energy_and_axial_momentum():
    """Case at rest, initial rates: 1e5 RK4 steps at a tenth of the stability limit.
    Realistic frequency separation (omega_max = 2e4 rad/s against rates ~0.3 rad/s):
    RK4 damps the highest modes at (h Omega)^6/72 per step, so a model whose modes
    held a large energy share would drift by that share, not by a modelling error."""
    chain, _ = synthetic_chain(seed=1, omega_max=2e4)
    y0, yd0 = free_state(chain)
    assert_checks(dc.conservation("free (synthetic)", chain, y0, yd0, n_steps=100_000, fraction=0.1))


@needs_numba
def test_energy_conserved_with_rotation_dofs_and_consistent_mass_short():
    chain, _ = synthetic_chain(seed=7, omega_max=2e4, rotations=(True, True, True, True),
                               consistent=(True, True, True, True))
    y0, yd0 = free_state(chain, rates=(0.2, 0.1, -0.3, 0.2))
    assert_checks(dc.conservation("free (all shells)", chain, y0, yd0, n_steps=20_000, fraction=0.1))


def test_rk4_order():
    chain, _ = synthetic_chain(seed=2, omega_max=60.0)
    y0, yd0 = free_state(chain)
    case = multibody.CaseMotion(amplitude=(1.0, 0.0, 0.0), frequency=(2.0, 0.0, 0.0))
    prob = Problem(chain, case=case, y0=y0, yd0=yd0)
    assert_checks(dc.rk4_order("synthetic, thesis-like case motion", prob, 0.2,
                               steps=(0.004, 0.002, 0.001)))


def test_rigid_limit_case_spin_about_outer_axis():
    chain, _ = synthetic_chain(seed=3)            # elastic: the closed form holds as well
    assert_checks(dc.rigid_spin_about_outer_axis("elastic synthetic", chain))
    from gimbal_reduction.results.bench.oracle import rigid_body
    rigid = multibody.Chain(tuple(rigid_body(n, 0.1, (0.3, 0.5, 0.4), com=(0.2, -0.1, 0.3))
                                  for n in (2, 3, 4, 5)))
    assert_checks(dc.rigid_spin_about_outer_axis("rigid, offset centres of mass", rigid))


def test_rigid_limit_motor_spin_up():
    inertias = [(0.05, 0.30, 0.55, 0.28), (0.04, 0.20, 0.37, 0.18),
                (0.03, 0.12, 0.22, 0.11), (0.02, 0.05, 0.09, 0.05)]
    assert_checks(dc.rigid_motor_spin_up("rigid chain", inertias))


def _thesis_like(chain):
    case = multibody.CaseMotion(amplitude=(1.0, 0.0, 0.0), frequency=(2.0, 0.0, 0.0))
    y0 = np.zeros(chain.n_coordinates)
    y0[1] = -np.pi / 2
    return Problem(chain, case=case, y0=y0)


@needs_numba
def test_generalized_alpha_second_order_when_modes_resolved():
    chain, _ = synthetic_chain(seed=6, omega_max=3e3)
    prob = _thesis_like(chain)
    t_end, dt = 0.05, 5e-4
    ref = integrators.integrate(prob, t_end, dt, method="rk4", fraction=0.1)
    errors = []
    for h in (6.25e-5, 3.125e-5):                      # h * omega_max = 0.19, 0.09
        run = integrators.integrate(prob, t_end, dt, method="generalized-alpha", step=h, rho_inf=0.9)
        errors.append(error_measure(run.t, ref.yd[:, :4], run.yd[:, :4]).max())
        assert run.stats["newton_not_converged"] == 0
    order = np.log2(errors[0] / errors[1]) / 2          # E is quadratic in the error
    assert 1.8 < order < 2.3, (errors, order)


@needs_numba
def test_generalized_alpha_far_beyond_rk4_limit_accuracy_measured():
    """Steps 27x RK4's limit: stable, and the rates' error measure E (thesis eq. 3.53)
    against an RK4 reference is measured: the modes above 1/h are filtered, which costs
    ~5e-6 here (it no longer falls with h: it is the filtered modes' share)."""
    chain, _ = synthetic_chain(seed=6, omega_max=3e5)
    prob = _thesis_like(chain)
    t_end, dt = 0.05, 5e-4
    ref = integrators.integrate(prob, t_end, dt, method="rk4", fraction=0.25)
    limit = integrators.rk4_stability_limit(chain.omega_max)
    h = 2.5e-4
    assert h > 25 * limit
    run = integrators.integrate(prob, t_end, dt, method="generalized-alpha", step=h, rho_inf=0.9)
    E = error_measure(run.t, ref.yd[:, :4], run.yd[:, :4])
    assert run.stats["newton_not_converged"] == 0
    assert E.max() < 1e-4, E


def test_dop853_agrees_with_rk4():
    chain, _ = synthetic_chain(seed=8, omega_max=200.0)
    case = multibody.CaseMotion(amplitude=(1.0, 0.0, 0.0), frequency=(2.0, 0.0, 0.0))
    prob = Problem(chain, case=case)
    a = integrators.integrate(prob, 0.1, 0.01, method="rk4", fraction=0.01)
    b = integrators.integrate(prob, 0.1, 0.01, method="dop853", rtol=1e-12, atol=1e-16)
    assert np.all(error_measure(a.t, a.yd[:, :4], b.yd[:, :4]) < 1e-10)


@needs_numba
def test_dop853_dense_outputs_match_the_method_restarted_at_every_sample():
    """``integrators``' DOP853 runs once over the window and reads the output times from its
    dense output; restarted at every output time (scipy's solve_ivp per interval, each output
    an end point, no interpolation), the same method gives the same motion to the tolerance's
    scale, in fewer steps when the output interval is shorter than the method's step."""
    from scipy.integrate import solve_ivp
    chain, _ = synthetic_chain(seed=6, omega_max=3e3)
    prob = _thesis_like(chain)
    t_end, dt, rtol, atol = 0.02, 2.5e-5, 1e-10, 1e-14
    run = integrators.integrate(prob, t_end, dt, method="dop853", rtol=rtol, atol=atol)
    n = prob.y0.size

    def f(t, z):
        return np.concatenate([z[n:], prob.rhs(t, z[:n], z[n:])])
    z, Y, restarted_steps = np.concatenate([prob.y0, prob.yd0]), [prob.y0], 0
    for a, b in zip(run.t[:-1], run.t[1:]):
        sol = solve_ivp(f, (a, b), z, method="DOP853", rtol=rtol, atol=np.full(2 * n, atol))
        z, restarted_steps = sol.y[:, -1], restarted_steps + sol.t.size - 1
        Y.append(z[:n])
    Y = np.array(Y)
    assert np.ptp(Y[:, :4], axis=0).max() > 1e-4             # the gimbals move
    assert np.abs(run.y - Y).max() <= 1e-8 * np.abs(Y).max()
    assert run.steps < restarted_steps


def test_rk4_step_beyond_limit_is_refused():
    chain, _ = synthetic_chain(seed=1, omega_max=1e3)
    prob = Problem(chain)
    limit = integrators.rk4_stability_limit(prob.omega_max)
    with pytest.raises(integrators.StepTooLargeError, match="exceeds the stability limit"):
        integrators.integrate(prob, 0.01, 0.001, method="rk4", step=1.01 * limit, model="m")


def test_divergence_is_detected_and_named():
    class Unstable:
        y0 = np.ones(5)
        yd0 = np.zeros(5)
        omega_max = 0.0
        rk4_steps = rk4_run = None      # no compiled paths

        def rhs(self, t, y, yd):
            return 1e6 * y

        def energy(self, t, y, yd):
            return float(0.5 * yd @ yd)

        def input_power(self, t, y, yd):
            return 0.0
    with pytest.raises(integrators.DivergenceError, match=r"t = .* model 'blowup', step"):
        integrators.integrate(Unstable(), 1.0, 0.01, method="rk4", step=1e-3, model="blowup")


def test_thesis_scene_energy_balance():
    """With the case driven, T + U changes by the work the case feeds in."""
    chain, _ = synthetic_chain(seed=9, omega_max=500.0)
    case = multibody.CaseMotion(amplitude=(1.0, 0.0, 0.0), frequency=(2.0, 0.0, 0.0))
    y0 = np.zeros(chain.n_coordinates)
    y0[1] = -np.pi / 2
    prob = Problem(chain, case=case, y0=y0)
    run = integrators.integrate(prob, 0.1, 1e-4, method="rk4", fraction=0.2)
    E = prob.energy(run.t[-1], run.y[-1], run.yd[-1]) - prob.energy(0.0, run.y[0], run.yd[0])
    assert abs(E - run.stats["energy_input"]) < 1e-4 * abs(E)


@needs_numba
def test_step_halving_convergence_check_on_synthetic_thesis_scene():
    """The truth-convergence check (run later on the real bodies) on a synthetic chain.
    Measured here: at RK4's default step (h omega_max = 1.4, half the limit) halving
    changes the rates by E ~ 7e-3 (the top modes are stable but not accurate, and these
    synthetic bodies couple them strongly); E falls as h^8 (fourth order) and E < 1e-10 needs h omega_max ~ 0.03."""
    chain, _ = synthetic_chain(seed=10, omega_max=2e4)
    assert_checks(dc.step_halving_convergence("synthetic thesis", _thesis_like(chain), 0.015, 1e-4,
                                              step=1.5e-6))


def test_coupled_frequencies_match_dense_pencil():
    """coupled_frequencies (Schur complement on the free joints) = the finite generalised
    eigenvalues of the full pencil (K, M(y)), K = diag(0_4, Omega^2)."""
    import scipy.linalg
    chain, _ = synthetic_chain(seed=4, omega_max=400.0)
    rng = np.random.default_rng(3)
    y = np.concatenate([rng.uniform(-3, 3, 4), 1e-3 * rng.normal(size=chain.n_coordinates - 4)])
    M = multibody.mass_matrix(chain, y)
    lam = scipy.linalg.eigh(np.diag(chain.stiffness_diagonal()), M, eigvals_only=True)
    w = linearized.coupled_frequencies(chain, y)
    assert np.allclose(np.sort(np.sqrt(np.maximum(lam, 0)))[4:], w, rtol=1e-9)
    # the joints' freedom raises the highest frequency above the largest kept modal one
    assert w[-1] > 1.5 * chain.omega_max


@needs_numba
def test_rk4_limit_from_coupled_frequency_regression():
    """The real-data divergence (docs/dynamics.md Section 6): RK4 at 0.9 x 2.785 / (largest kept
    modal frequency) blows up because the coupled chain's top frequency is higher; at 0.9 x the
    coupled limit it is stable."""
    chain, _ = synthetic_chain(seed=4, omega_max=400.0)
    y0, yd0 = free_state(chain)
    prob = Problem(chain, y0=y0, yd0=yd0)
    assert prob.omega_max > 2 * prob.modal_omega_max
    old = 0.9 * integrators.rk4_stability_limit(prob.modal_omega_max)
    with pytest.raises(integrators.StepTooLargeError):
        integrators.integrate(prob, 0.5, 0.01, method="rk4", step=old)
    prob_old = Problem(chain, y0=y0, yd0=yd0, omega_max=prob.modal_omega_max)
    with pytest.raises(integrators.DivergenceError):
        integrators.integrate(prob_old, 0.5, 0.01, method="rk4", step=old)
    run = integrators.integrate(prob, 0.5, 0.01, method="rk4", fraction=0.9)
    E = [prob.energy(t, y, v) for t, y, v in zip(run.t, run.y, run.yd)]
    assert abs(E[-1] - E[0]) < 1e-6 * E[0]


@needs_numba
def test_compiled_rk4_loop_energy_and_case_power_match_reference():
    chain, _ = synthetic_chain(seed=4, damping_ratio=0.01)
    case = multibody.CaseMotion(amplitude=(1.0, 0.3, -0.2), frequency=(2.0, 1.0, 0.0),
                                omega0=(0.1, 0.0, 0.2))
    torque = (0.1, 0.0, -0.2, 0.05)
    fast = Problem(chain, case=case, torque=torque)
    ref = Problem(chain, case=case, torque=torque, fast=False)
    assert fast.rk4_steps is not None and ref.rk4_steps is None
    rng = np.random.default_rng(0)
    n = chain.n_coordinates
    y = np.concatenate([rng.uniform(-3, 3, 4), 0.02 * rng.normal(size=n - 4)])
    yd = rng.normal(size=n)
    a = fast.rk4_steps(y, yd, 0.1, 1e-4, 20)
    b = integrators.rk4_steps(ref.rhs, y, yd, 0.1, 1e-4, 20)
    assert dc.relative_difference(a[0], b[0]) < 1e-12 and dc.relative_difference(a[1], b[1]) < 1e-12
    # the compiled loop carries sum_j q_j G_j from stage to stage instead of recomputing it:
    # over 150 steps in one call it must still agree to round-off
    a = fast.rk4_steps(y, yd, 0.1, 1e-4, 150)
    b = integrators.rk4_steps(ref.rhs, y, yd, 0.1, 1e-4, 150)
    assert dc.relative_difference(a[0], b[0]) < 1e-12 and dc.relative_difference(a[1], b[1]) < 1e-12
    assert fast.energy(0.3, y, yd) == pytest.approx(ref.energy(0.3, y, yd), rel=1e-12)
    assert fast.input_power(0.3, y, yd) == pytest.approx(ref.input_power(0.3, y, yd), rel=1e-10)


def _without_whole_run(prob):
    """The same problem run through the per-interval compiled loop and the Python monitor."""
    prob.rk4_run = None
    return prob


@needs_numba
def test_compiled_whole_run_matches_per_interval_loop_and_monitor():
    """integrate's compiled whole RK4 run (energy watch included) gives the states, the
    energy terms and the input work of the per-interval loop with the Python monitor."""
    chain, _ = synthetic_chain(seed=4, damping_ratio=0.01, omega_max=300.0)
    case = multibody.CaseMotion(amplitude=(1.0, 0.3, -0.2), frequency=(20.0, 10.0, 0.0),
                                omega0=(0.1, 0.0, 0.2))
    torque = (0.1, 0.0, -0.2, 0.05)
    y0 = np.zeros(chain.n_coordinates)
    y0[:4] = (0.3, -1.2, 0.4, 0.1)
    yd0 = np.zeros(chain.n_coordinates)
    yd0[:4] = (0.5, -0.3, 0.2, 0.4)
    whole = Problem(chain, case=case, torque=torque, y0=y0, yd0=yd0)
    loop = _without_whole_run(Problem(chain, case=case, torque=torque, y0=y0, yd0=yd0))
    assert whole.rk4_run is not None and loop.rk4_run is None
    a = integrators.integrate(whole, 0.05, 1e-3, method="rk4", fraction=0.8)
    b = integrators.integrate(loop, 0.05, 1e-3, method="rk4", fraction=0.8)
    assert a.steps == b.steps and a.step == b.step
    assert dc.relative_difference(a.y, b.y) < 1e-13 and dc.relative_difference(a.yd, b.yd) < 1e-13
    for key in ("kinetic", "potential", "power", "input_work"):
        assert dc.relative_difference(a.energy[key], b.energy[key]) < 1e-12, key
    assert a.stats["energy_input"] == pytest.approx(b.stats["energy_input"], rel=1e-12)
    assert abs(a.energy["input_work"][-1]) > 1e-4 * abs(a.energy["kinetic"][-1])   # not trivial


@needs_numba
def test_compiled_whole_run_stops_divergence_like_the_monitor():
    """Beyond the true stability limit both paths stop at the same sample with the same message."""
    chain, _ = synthetic_chain(seed=4, omega_max=400.0)
    y0, yd0 = free_state(chain)
    msgs = []
    for prob in (Problem(chain, y0=y0, yd0=yd0),
                 _without_whole_run(Problem(chain, y0=y0, yd0=yd0))):
        prob.omega_max = prob.modal_omega_max          # the old, too optimistic limit
        step = 0.9 * integrators.rk4_stability_limit(prob.omega_max)
        with pytest.raises(integrators.DivergenceError) as err:
            integrators.integrate(prob, 0.5, 0.01, method="rk4", step=step, model="m")
        msgs.append(str(err.value))
    assert msgs[0] == msgs[1] and "energy" in msgs[0]

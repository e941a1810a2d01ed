"""Verification of the modal exponential integrator (``gimbal_reduction.solver.dynamics.exponential``).

What is checked, each against something computed independently of the module:

1. ``phi_functions`` against phi_k(z) = int_0^1 e^{(1-s) z} s^(k-1)/(k-1)! ds by
   ``scipy.integrate.quad`` (real and imaginary parts), on both branches (Taylor series
   below ``SERIES_RADIUS``, recurrence above), at the branch radius from both sides and
   far out (|z| = 1e4 on and left of the imaginary axis).
2. The linear part is solved exactly: one ``advance`` of a hand-made linear chain
   M y'' + C y' + K y = f(t) (constant M, 4 joints, 2 elastic coordinates, polynomial
   f of degree <= 3) at omega_max h = 1e3, undamped and with 1 % damping, against the
   exact solution of the augmented linear system (matrix exponential, Van Loan), itself
   checked against ``solve_ivp``.
3. Whole runs (``integrators.integrate(method="exponential")``) on small synthetic
   chains against the converged DOP853 (rtol 1e-10): thesis-like and damped case motion,
   and a free scene with large rates (re-linearisations).
4. The observed order of the fixed-step scheme.
5. Agreement with RK4 at 5 % of its stability limit on a reduced synthetic model.
6. Bad input is refused before any work (the right-hand side is never called).
7. Failure modes: a frozen basis beyond its validity, a non-finite right-hand side.
8. Energy conservation in a free scene over many steps.

E is the thesis error measure (eq. 3.53) of the four gimbal rates, max over the rates.
Units: in, lbf, s, rad.
"""

import cmath
import copy
import functools
import math
import re

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import quad, solve_ivp

from gimbal_reduction.results.bench.oracle import synthetic_chain
from gimbal_reduction.solver.dynamics import exponential, integrators, scenes, simulate
from gimbal_reduction.solver.dynamics.kernels import exponential as kernels
from gimbal_reduction.solver.dynamics.error_measure import error_measure

# ----------------------------------------------------------------------------- helpers
# Synthetic chains (gimbal_reduction.results.bench.oracle): keyword sets of ``synthetic_chain``.
# FULL: 13 coordinates, coupled omega_max 3.9e4 rad/s (the exponential steps at
#   h omega_max ~ 12, beyond RK4's limit 2.785).
# STIFF_REDUCED: 9 coordinates, strongly coupled (coupled omega_max 9.8e4 rad/s, ten
#   times the largest kept modal frequency).
# SOFT: FULL's bodies at omega_max 2e3 (coupled 3.9e3 rad/s): cheap references.
# REDUCED: SOFT with one or two modes per body (coupled 3.4e3 rad/s).
FULL = dict(seed=3, omega_max=2e4)
STIFF_REDUCED = dict(seed=11, omega_max=1e4, n_modes=(2, 1, 1, 1))
SOFT = dict(seed=3, omega_max=2e3)
REDUCED = dict(seed=3, omega_max=2e3, n_modes=(2, 1, 1, 1))


def scene_with(name, **values):
    """The scene config/scenes/{name}.yaml with some top-level values replaced (parse_scene)."""
    raw = copy.deepcopy(scenes.load_scene(name).raw)
    for key, value in values.items():
        raw[key]["value"] = value
    return scenes.parse_scene(raw, origin=f"{name} (test copy)")


def problem(chain_kw, scene):
    chain, _ = synthetic_chain(damping_ratio=scene.damping_ratio, **chain_kw)
    return simulate.scene_problem(chain, scene)


def run(prob, scene, method="exponential", **options):
    return integrators.integrate(prob, scene.duration, scene.output_interval, method=method,
                                 **options)


@functools.lru_cache(maxsize=None)
def dop853_reference(scene_name, chain_name):
    """(scene, problem, converged DOP853 run (rtol 1e-10)) of a named chain in a named scene."""
    scene = scenes.load_scene(scene_name)
    prob = problem(globals()[chain_name], scene)
    return scene, prob, run(prob, scene, method="dop853", rtol=1e-10, atol=1e-14)


def E_max(reference, other):
    """Max over the four gimbal rates of the error measure (eq. 3.53) of run ``other``."""
    return float(np.max(error_measure(reference.t, reference.yd[:, :4], other.yd[:, :4])))


def time_in_message(message):
    """The time t [s] a one-line error message names ("t = <number> s")."""
    found = re.search(r"t = ([-+0-9.eE]+) s", message)
    assert found, f"no time 't = ... s' in {message!r}"
    return float(found.group(1))


# ----------------------------------------------------------------- 1. phi functions
def phi_by_quadrature(z, k):
    """phi_k(z), k >= 1, = int_0^1 e^{u z} (1-u)^(k-1)/(k-1)! du (u = 1 - s) by quad:
    real and imaginary parts separately, QAWO (weight cos / sin) for fast oscillation,
    the interval cut where e^{x u} < e^-40 when Re z = x << 0."""
    x, y = z.real, z.imag
    fact = math.factorial(k - 1)

    def amplitude(u):
        return math.exp(x * u) * (1.0 - u) ** (k - 1) / fact
    b = 1.0 if x > -40.0 else 40.0 / -x
    kw = dict(epsabs=0.0, epsrel=1e-12, limit=500)
    if abs(y) > 50.0:
        re_part = quad(amplitude, 0.0, b, weight="cos", wvar=y, **kw)[0]
        im_part = quad(amplitude, 0.0, b, weight="sin", wvar=y, **kw)[0]
    else:
        re_part = quad(lambda u: amplitude(u) * math.cos(y * u), 0.0, b, **kw)[0]
        im_part = quad(lambda u: amplitude(u) * math.sin(y * u), 0.0, b, **kw)[0]
    return complex(re_part, im_part)


R = exponential.SERIES_RADIUS
PHI_POINTS = {
    "small": [1e-3, -0.5, 0.3j, -0.5 + 1.2j, -1.2 - 0.7j, 1.5j],
    "radius inside": [R * (1 - 1e-9) * np.exp(1j * a) for a in (np.pi / 2, 3 * np.pi / 4, np.pi)],
    "radius outside": [R * (1 + 1e-9) * np.exp(1j * a) for a in (np.pi / 2, 3 * np.pi / 4, np.pi)],
    "moderate": [5j, -3.0 + 4.0j, -30.0 + 10.0j],
    "large": [1e3j, 1e4j, -1e4j, -1e2 + 1e4j, -1e4 + 1e4j, -5e3, -1e4],
}


@pytest.mark.parametrize("where", list(PHI_POINTS))
def test_phi_functions_match_quadrature(where):
    # all points in one call: the two branches are selected per entry
    z = np.array(PHI_POINTS[where], complex)
    phi = exponential.phi_functions(z, 6)
    assert phi.shape == (7, z.size) and np.iscomplexobj(phi)
    for i, zi in enumerate(z):
        assert abs(phi[0, i] - cmath.exp(zi)) <= 1e-14 * abs(cmath.exp(zi))
        for k in range(1, 7):
            ref = phi_by_quadrature(complex(zi), k)
            # measured: worst 1e-14 relative (near |z| = R, k = 6)
            assert abs(phi[k, i] - ref) <= 1e-11 * abs(ref), (zi, k, phi[k, i], ref)


def test_phi_functions_at_zero_are_inverse_factorials():
    phi = exponential.phi_functions(np.zeros(3), 6)
    for k in range(7):
        assert np.all(np.abs(phi[k] - 1.0 / math.factorial(k)) <= 1e-16 / math.factorial(k)), k


# ------------------------------------------------------ 2. the linear part is exact
def linear_chain(coupled, zeta, seed):
    """(M, K, C): a constant SPD mass matrix (6, 6) (4 joints, 2 elastic coordinates;
    ``coupled``: the joints and the elastic coordinates inertially coupled, so the coupled
    modes mix them and phi^T C phi is not diagonal), stiffness and damping diagonals (6,)
    (zero on the joints; C = 2 zeta Omega as the chains have)."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(4, 4))
    M = np.eye(6)
    M[:4, :4] = A @ A.T + 4.0 * np.eye(4)
    if coupled:
        B = 0.3 * rng.normal(size=(6, 6))
        M += B @ B.T
    Omega = np.array([1.0, 0.37])
    K = np.concatenate([np.zeros(4), Omega ** 2])
    C = np.concatenate([np.zeros(4), 2.0 * zeta * Omega])
    return M, K, C


def exact_linear_step(M, K, C, F, h, H, y0, v0, v_scale):
    """(y, y') (6,) at t = H of M y'' + C y' + K y = sum_j F[j] (t/h)^j from (y0, v0) at
    t = 0, exactly: the augmented linear system in (y, y'/v_scale, 1, t/h, (t/h)^2, ...)
    is homogeneous, so its state at H is expm(A H) times the initial one (Van Loan).
    v_scale [1/s] balances the blocks of A."""
    n, terms = M.shape[0], F.shape[0]
    Minv = np.linalg.inv(M)
    N = 2 * n + terms
    A = np.zeros((N, N))
    A[:n, n:2 * n] = v_scale * np.eye(n)
    A[n:2 * n, :n] = -Minv * K[None, :] / v_scale
    A[n:2 * n, n:2 * n] = -Minv * C[None, :]
    A[n:2 * n, 2 * n:] = Minv @ F.T / v_scale
    for j in range(1, terms):                       # d/dt (t/h)^j = (j/h) (t/h)^(j-1)
        A[2 * n + j, 2 * n + j - 1] = j / h
    w0 = np.concatenate([y0, v0 / v_scale, [1.0], np.zeros(terms - 1)])
    w = scipy.linalg.expm(A * H) @ w0
    return w[:n], w[n:2 * n] * v_scale


def linear_case(coupled, zeta, degree, seed=0):
    """A linearised chain (``exponential.linearise``), its step h (omega_max h = 1e3), a
    forcing F (degree + 1, 6) and an initial state, scaled so that every coordinate moves
    by O(1) over the step (joint forces ~ 1/h^2, rates ~ 1/h; elastic forces ~ Omega^2)."""
    M, K, C = linear_chain(coupled, zeta, seed)
    rng = np.random.default_rng(100 + seed)
    y_lin = np.concatenate([rng.uniform(-1, 1, 4), np.zeros(2)])
    basis = exponential.linearise(lambda y: M, K, C, y_lin)
    omega_max = float(np.max(basis.omega))
    h = 1e3 / omega_max
    F = rng.normal(size=(degree + 1, 6)) * np.concatenate([np.full(4, h ** -2), K[4:]])
    y0 = y_lin + rng.normal(size=6)
    v0 = rng.normal(size=6) * np.concatenate([np.full(4, 1.0 / h), np.sqrt(K[4:])])
    return M, K, C, basis, omega_max, h, F, y0, v0


def relative_error_by_block(x, exact, start=None):
    """max |x - exact| / max |exact| over the joints and over the elastic coordinates (the
    larger of the two): each block judged on its own scale, at least the block's scale at the
    start if given (a heavily damped block decays to rounding over the step)."""
    start = np.zeros_like(exact) if start is None else start
    return max(np.max(np.abs(x[b] - exact[b])) / max(np.max(np.abs(exact[b])), np.max(np.abs(start[b])))
               for b in (slice(0, 4), slice(4, None)))


@pytest.mark.parametrize("theta", [1.0, 0.3], ids=["step", "dense output"])
@pytest.mark.parametrize("degree", [0, 1, 2, 3])
@pytest.mark.parametrize("zeta", [0.0, 0.01, 0.2, 0.5, 1.0, 2.0])
@pytest.mark.parametrize("coupled", [False, True], ids=["diagonal mass", "coupled mass"])
def test_advance_is_exact_for_polynomial_forcing(coupled, zeta, degree, theta):
    """With g = Phi^T f a polynomial of degree <= 3 the step is exact, at omega h = 1e3 (350x
    RK4's stability limit), at any damping: underdamped, overdamped (real eigenvalues) and, with
    the diagonal mass, exactly critical (both modes at damping ratio 1: the bank is nudged off
    it, ``CoupledBank``).  Measured: <= 5e-12 relative (1e-14 typically)."""
    M, K, C, basis, omega_max, h, F, y0, v0 = linear_case(coupled, zeta, degree)
    assert omega_max * h == pytest.approx(1e3)
    H = theta * h
    eta, etad = basis.to_modal(y0, v0)
    # M0 a = f - C y' - K y, so g = Phi^T M0 a + Lambda eta + Phi^T C Phi eta' = Phi^T f
    coef = F @ basis.phi
    weights = exponential.StepWeights(basis, 3)
    eta1, etad1 = exponential.advance(basis, weights, eta, etad, coef, H, theta)
    y1, v1 = basis.to_physical(eta1, etad1)
    y_ex, v_ex = exact_linear_step(M, K, C, F, h, H, y0, v0, omega_max)
    assert relative_error_by_block(y1, y_ex, y0) <= 1e-10, (y1, y_ex)
    assert relative_error_by_block(v1, v_ex, v0) <= 1e-10, (v1, v_ex)


@pytest.mark.parametrize("zeta", [0.01, 0.2, 1.0, 2.0])
@pytest.mark.parametrize("coupled", [False, True], ids=["diagonal mass", "coupled mass"])
def test_damped_dense_outputs_match_the_advance_and_the_exact_solution(coupled, zeta):
    """The damped bank's dense outputs of one step (``kernels.exponential.dense_coupled``: the
    start and the forcing mapped to the bank once, all outputs back by one real product) at
    four points inside a step of h (omega_max h = 1e3), against one ``advance`` per point (the
    loop's former route) and against the exact solution (Van Loan); underdamped, overdamped
    and, with the diagonal mass at zeta = 1, nudged off critical damping.  Each block of the
    modal state is judged on its own scale (``relative_error_by_block``).  Measured: <= 1.6e-15
    against the advance, <= 2.4e-12 against the exact solution (the nudged critical case)."""
    M, K, C, basis, omega_max, h, F, y0, v0 = linear_case(coupled, zeta, 3)
    bank = basis.bank
    assert isinstance(bank, exponential.CoupledBank)
    eta, etad = basis.to_modal(y0, v0)
    coef = np.ascontiguousarray(F @ basis.phi)
    ticks, offset, spacing, count = 16, 3, 4, 4           # outputs at 3, 7, 11, 15 ticks of h / 16
    tick = h / ticks
    out_eta, out_etad = np.empty((count, eta.size)), np.empty((count, eta.size))
    kernels.dense_coupled(eta, etad, coef, bank.mu, bank.P_eta, bank.P_vel, bank.V_real, h, tick,
                          offset, spacing, count, exponential.SERIES_RADIUS,
                          exponential.SERIES_TERMS, exponential._INV_FACTORIALS,
                          exponential._FACTORIALS, out_eta, out_etad)
    weights = exponential.StepWeights(basis, 3)
    for k in range(count):
        H = (offset + k * spacing) * tick
        eta1, etad1 = exponential.advance(basis, weights, eta, etad, coef, H, H / h)
        assert relative_error_by_block(out_eta[k], eta1, eta) <= 1e-13, (k, out_eta[k], eta1)
        assert relative_error_by_block(out_etad[k], etad1, etad) <= 1e-13, (k, out_etad[k], etad1)
        y1, v1 = basis.to_physical(out_eta[k], out_etad[k])
        y_ex, v_ex = exact_linear_step(M, K, C, F, h, H, y0, v0, omega_max)
        assert relative_error_by_block(y1, y_ex, y0) <= 1e-10, (k, y1, y_ex)
        assert relative_error_by_block(v1, v_ex, v0) <= 1e-10, (k, v1, v_ex)


def critical_pair():
    """(Omega (2,) [rad/s], Ct (2, 2) [1/s]): two uncoupled modes at damping ratio 1 exactly,
    whose bank must be nudged off critical damping (``CoupledBank``)."""
    omega = np.array([1.0, 0.37])
    return omega, np.diag(2.0 * omega)


def test_a_new_bank_tries_the_nudge_a_previous_one_needed_first():
    """At critical damping the nominal try fails the condition check: the fresh bank takes
    more than one eigendecomposition, one started from the nudge it settled on takes one, and
    solves the same damping (eigenvalues to rounding of their magnitude)."""
    omega, Ct = critical_pair()
    fresh = exponential.CoupledBank(omega, Ct)
    assert fresh.nudge != 0 and fresh.decompositions > 1, (fresh.nudge, fresh.decompositions)
    again = exponential.CoupledBank(omega, Ct, first_nudge=fresh.nudge)
    assert again.nudge == fresh.nudge and again.decompositions == 1
    np.testing.assert_allclose(again.damping, fresh.damping, rtol=1e-15, atol=0.0)
    np.testing.assert_allclose(again.mu, fresh.mu, rtol=0.0, atol=1e-12 * np.abs(fresh.mu).max())
    # a light damping needs no nudge: the nominal one is taken whatever comes first
    light = exponential.CoupledBank(omega, 0.02 * np.diag(omega), first_nudge=1)
    assert light.nudge == 1 and light.decompositions == 1
    assert exponential.CoupledBank(omega, 0.02 * np.diag(omega)).nudge == 0


def test_a_condition_that_no_nudge_lowers_takes_one_decomposition():
    """A fast damped mode (1e7 rad/s, damping ratio 0.5) has condition ~|mu| ~ 1.2e7 beyond
    NUDGE_CONDITION from the scales of eta and eta' ~ |mu| eta alone, far from critical
    damping (``CoupledBank.nudge_can_help``), alone or beside a mode 1e-6 away in frequency:
    the nominal damping after one decomposition, kept below CONDITION_LIMIT.  With a critical
    pair beside it the nudges are tried."""
    for omega in ([1e7, 3.0], [1e7, 1e7 * (1 + 1e-6)]):    # alone; beside a mode of ~its frequency
        omega = np.array(omega)
        fast = exponential.CoupledBank(omega, np.diag(omega))
        condition = exponential.CoupledBank._decompose(omega, fast.damping, 0.0)[3]
        assert condition.max() > exponential.CoupledBank.NUDGE_CONDITION
        assert fast.nudge == 0 and fast.decompositions == 1
    omega, Ct = critical_pair()
    both = exponential.CoupledBank(np.concatenate([[1e7], omega]),
                                   scipy.linalg.block_diag([[1e7]], Ct))
    assert both.nudge != 0 and both.decompositions > 1


@pytest.mark.parametrize("first_nudge", [0, -1, 1])
def test_the_nudge_order_leaves_the_refusal_as_strict(first_nudge):
    """Whatever is tried first: a bank whose every try fails the nudge check gets the up
    nudge after all three tries, and is refused when that one is beyond the limit."""
    omega, Ct = critical_pair()

    class Strict(exponential.CoupledBank):
        NUDGE_CONDITION = 0.0                  # no try passes
        CONDITION_LIMIT = np.inf

    bank = Strict(omega, Ct, first_nudge=first_nudge)
    assert bank.nudge == 1 and bank.decompositions == 3

    class Refusing(Strict):
        CONDITION_LIMIT = 1.0                  # below any condition number (>= 1)

    with pytest.raises(exponential.ExponentialError, match="cannot be diagonalised"):
        Refusing(omega, Ct, first_nudge=first_nudge)


def test_a_bad_first_nudge_is_refused():
    omega, Ct = critical_pair()
    with pytest.raises(ValueError, match="first_nudge 0.5"):
        exponential.CoupledBank(omega, Ct, first_nudge=0.5)


@pytest.mark.parametrize("zeta", [0.0, 0.01], ids=["undamped", "damped"])
def test_exact_linear_step_agrees_with_solve_ivp(zeta):
    """The reference of the test above against DOP853 at rtol 1e-12 (measured 7e-13)."""
    M, K, C, basis, omega_max, h, F, y0, v0 = linear_case(True, zeta, 3)
    Minv = np.linalg.inv(M)
    n = M.shape[0]

    def f(t, z):
        force = sum(F[j] * (t / h) ** j for j in range(F.shape[0]))
        return np.concatenate([z[n:], Minv @ (force - C * z[n:] - K * z[:n])])
    sol = solve_ivp(f, (0.0, h), np.concatenate([y0, v0]), method="DOP853", rtol=1e-12, atol=1e-14)
    y_ex, v_ex = exact_linear_step(M, K, C, F, h, h, y0, v0, omega_max)
    assert relative_error_by_block(sol.y[:n, -1], y_ex) <= 1e-9
    assert relative_error_by_block(sol.y[n:, -1], v_ex) <= 1e-9


# ------------------------------------------- 2b. the basis's factored form and updates
def test_factored_basis_matches_the_generalised_eigenproblem():
    """``linearized.free_joint_basis`` (stiffness-scaled standard problem) against the
    generalised pencil of ``free_joint_modes`` on a strongly coupled synthetic chain at a
    turned configuration: the same frequencies, X^T S X = I, Y = S X = X^-T, and phi^-1 as
    applied by ``ModalBasis.project`` inverts ``to_physical``.  Measured: frequencies 9e-15
    relative, X^T S X - I 1e-14, Y^T X - I 1e-15."""
    from gimbal_reduction.solver.dynamics import linearized
    chain, _ = synthetic_chain(**STIFF_REDUCED)
    prob = simulate.scene_problem(chain, scenes.load_scene("thesis"))
    y = prob.y0.copy()
    y[:4] += [0.3, -0.2, 0.5, 0.1]
    M = prob.mass_matrix(y)
    k = prob.stiffness_diagonal[4:]
    om_ref, shapes = linearized.free_joint_modes(M, k)
    om, J, X, Y = linearized.free_joint_basis(M, k)
    _, S = linearized.free_joints(M)
    I = np.eye(k.size)
    assert np.allclose(om, om_ref, rtol=1e-10, atol=0)
    assert np.max(np.abs(X.T @ S @ X - I)) <= 1e-10
    assert np.max(np.abs(Y.T @ X - I)) <= 1e-10
    assert np.max(np.abs(Y - S @ X)) <= 1e-10 * np.max(np.abs(Y))
    assert np.allclose(linearized.free_joint_frequencies(M, k), om, rtol=1e-10, atol=0)
    basis = exponential.linearise(prob.mass_matrix, prob.stiffness_diagonal,
                                  prob.damping_diagonal, y)
    rng = np.random.default_rng(1)
    eta, etad = rng.normal(size=y.size), rng.normal(size=y.size)
    yy, yyd = basis.to_physical(eta, etad)
    assert np.allclose(yy, basis.y_ref + basis.phi @ eta, rtol=0, atol=1e-12 * np.abs(yy).max())
    e2, ed2 = basis.to_modal(yy, yyd)
    assert np.max(np.abs(e2 - eta)) <= 1e-9 and np.max(np.abs(ed2 - etad)) <= 1e-9
    assert np.max(np.abs(basis.phi.T @ basis.M0 @ basis.phi - np.eye(y.size))) <= 1e-9


def test_rayleigh_frequencies_follow_the_coupled_frequencies():
    """The frequency update of a frozen basis (``ModalBasis.rayleigh_frequencies``): at the
    basis's own configuration the frequencies themselves; after 1e-3 rad of gimbal motion
    the coupled frequencies there, up to a small fraction of their shift (the shapes' error
    enters the Rayleigh quotient squared).  Measured on STIFF_REDUCED: shift 1.0e-4
    relative, Rayleigh quotients within 3.2e-7 relative of the new eigenfrequencies."""
    chain, _ = synthetic_chain(**STIFF_REDUCED)
    prob = simulate.scene_problem(chain, scenes.load_scene("thesis"))
    basis = exponential.linearise(prob.mass_matrix, prob.stiffness_diagonal,
                                  prob.damping_diagonal, prob.y0)
    w0 = basis.omega[4:]
    assert np.allclose(basis.rayleigh_frequencies(basis.M0), w0, rtol=1e-12, atol=0)
    y = prob.y0.copy()
    y[:4] += [1e-3, -1e-3, 5e-4, 1e-3]
    M = prob.mass_matrix(y)
    exact = exponential.coupled_frequencies_at(M, prob.stiffness_diagonal)
    rq = basis.rayleigh_frequencies(M)
    shift = np.max(np.abs(exact / w0 - 1))
    assert shift > 1e-7                                    # the frequencies do move
    assert np.max(np.abs(rq / exact - 1)) <= 1e-2 * shift
    updated = basis.with_frequencies(rq)
    assert np.array_equal(updated.phi, basis.phi) and np.array_equal(updated.omega[4:], rq)
    assert np.array_equal(updated.omega_ref, basis.omega_ref)
    # the same quotients from the composite factors of M (no M, no (m, m, m) product): measured
    # 1e-15 relative here (5e-11 in the top modes of the truth model, as the dense ones' own error)
    factored = basis.rayleigh_frequencies_factored(prob.mass_factors(y))
    assert np.max(np.abs(factored / rq - 1)) <= 1e-12
    assert np.max(np.abs(basis.rayleigh_frequencies_factored(prob.mass_factors(prob.y0)) / w0 - 1)) <= 1e-12


def test_phase_error_is_met_by_frequency_updates_not_new_bases():
    """STIFF_REDUCED on thesis (the chain whose frozen basis loses its phase, E 1.1e-7,
    test above): the gimbals turn by ~1e-4 rad only, so the phase error is met by new
    frequencies of the same shapes (here for 5 modes, below frequency_update_min_modes,
    where a new basis is the cheaper answer: the mechanism is tested).  Measured: 7
    frequency updates, one basis, E 6.0e-9 (the same E as with 8 bases)."""
    scene, prob, ref = dop853_reference("thesis", "STIFF_REDUCED")
    r = run(prob, scene, frequency_update_min_modes=1)
    assert r.stats["frequency_updates"] >= 1 and r.stats["relinearisations"] == 0, r.stats
    assert E_max(ref, r) <= 1e-8
    # a problem without the mass matrix's factors (NumPy path): the frequencies from M itself,
    # the same run to rounding
    dense = copy.copy(prob)
    dense.mass_factors = lambda y: None
    r_dense = run(dense, scene, frequency_update_min_modes=1)
    assert (r_dense.steps, r_dense.stats["frequency_updates"]) == (r.steps, r.stats["frequency_updates"])
    assert E_max(r, r_dense) <= 1e-12


def test_the_phase_is_held_to_its_own_bound_not_the_step_tolerance():
    """The frozen frequencies' phase error asks for new frequencies beyond min(tol, phase_tol)
    (``ExponentialOptions.phase_bound``): a looser step tolerance does not loosen it.  STIFF_REDUCED on
    thesis at tol 1e-4: with the bound, 4 frequency updates and E 9.5e-9; with the bound at the
    tolerance itself (phase_tol raised) 2 updates and E 2.9e-8."""
    options = exponential.ExponentialOptions
    assert options(tol=1e-4).phase_bound == exponential.DEFAULTS.phase_tol
    assert options(tol=1e-7).phase_bound == 1e-7
    assert options(step=1e-4).phase_bound == exponential.DEFAULTS.phase_tol
    scene, prob, ref = dop853_reference("thesis", "STIFF_REDUCED")
    bound = run(prob, scene, tol=1e-4, frequency_update_min_modes=1)
    at_tol = run(prob, scene, tol=1e-4, frequency_update_min_modes=1, phase_tol=1.0)
    assert bound.stats["frequency_updates"] > at_tol.stats["frequency_updates"], \
        (bound.stats["frequency_updates"], at_tol.stats["frequency_updates"])
    assert E_max(ref, bound) < E_max(ref, at_tol), (E_max(ref, bound), E_max(ref, at_tol))



@pytest.mark.parametrize("scene_name", ["thesis", "stress_rates_10"])
def test_one_evaluation_per_step_matches_two(scene_name):
    """The default adaptive step is PEC: the accepted node keeps the predicted state's g
    (``evaluate_accepted`` False), one evaluation per step besides the first step's midpoint;
    PECE evaluates again at every accepted state.  Both against the converged DOP853, E <= 1e-8,
    and PEC no worse than 2x PECE (thesis: one basis and frequency updates; stress_rates_10:
    the gimbals turn 0.15 rad, new bases, whose state must be the accepted one, not the newest
    node's predicted one).  Measured on FULL, PEC against PECE: thesis 52 steps,
    55 against 106 evaluations, E 1.43e-10 both; stress_rates_10 230 steps, 20 bases, 242
    against 471 evaluations, E 1.15e-10 against 1.08e-10."""
    scene, prob, ref = dop853_reference(scene_name, "FULL")
    pec = run(prob, scene)
    pece_run = run(prob, scene, evaluate_accepted=True)
    for r in (pec, pece_run):
        assert E_max(ref, r) <= 1e-8, (E_max(ref, r), r.stats)
    assert E_max(ref, pec) <= 2.0 * E_max(ref, pece_run), (E_max(ref, pec), E_max(ref, pece_run))
    # evaluations: PEC one per attempt (+ the first step's midpoint and final evaluation, the
    # start's); PECE two per accepted step
    s = pec.stats
    assert s["evaluations"] <= pec.steps + s["rejected"] + 3, s
    assert pece_run.stats["evaluations"] >= 2 * pece_run.steps, pece_run.stats
    if scene_name == "stress_rates_10":
        assert s["relinearisations"] >= 3, s


# -------------------------------------------------- 3. against the converged DOP853
@pytest.mark.parametrize("scene_name, chain_name", [
    ("thesis", "FULL"),              # measured E: 2.5e-9 at the default tol, 6.5e-15 at tol/100
    ("damped", "FULL"),              # 2.4e-10, 2.2e-14
    ("smooth", "FULL"),              # from rest, forcing from zero: the first step's estimate
                                     # (one node) was 100 % at any step before the midpoint start
    ("thesis", "STIFF_REDUCED"),     # 1.1e-7 (fails), 3.2e-10
])
def test_moving_case_matches_converged_dop853(scene_name, chain_name):
    """E <= 1e-8 at the default tolerance, and 10x smaller at a 100x tighter one.

    STIFF_REDUCED measured: E = 1.13e-7 at every tol from 1e-4 to 1e-6 (25 to 137 steps,
    no new basis: the gimbals turn by 1e-4 rad only), 3.2e-10 at 1e-7 (7 bases, built
    after rejections).  The error grows steadily over the window and falls with the
    basis age, not the step: drift=2e-5 rad gives 1.8e-8, 5e-6 rad 7.2e-9; fixed step
    8e-5 s frozen 1.1e-7, re-linearised every 8e-4 s 9.1e-10.  The top coupled mode
    (9.7e4 rad/s) shifts by 8.7e-6 relative over the window (phase 1.3e-2 rad by
    0.015 s): the frozen basis's phase error, which the corrector - predictor estimate
    does not see."""
    scene, prob, ref = dop853_reference(scene_name, chain_name)
    loose = run(prob, scene)                                          # the default tol
    tight = run(prob, scene, tol=exponential.DEFAULTS.tol / 100)
    E_loose, E_tight = E_max(ref, loose), E_max(ref, tight)
    # the exponential integrator steps where an explicit method cannot
    assert loose.stats["largest_step"] * prob.omega_max > integrators.RK4_STABILITY
    assert E_loose <= 1e-8, (E_loose, loose.steps, loose.stats)
    # 10x smaller, unless both sit at the comparison's round-off floor (smooth: 3.7e-15)
    assert E_tight <= max(0.1 * E_loose, 1e-13), (E_tight, E_loose)


@pytest.mark.parametrize("zeta, overdamped", [(0.2, False), (0.5, True), (1.0, True), (2.0, True)])
def test_heavy_damping_matches_converged_dop853(zeta, overdamped):
    """Modal damping up to critical and beyond (scene damped with damping_ratio zeta): the
    coupled modes whose damping passes critical are pairs of real eigenvalues, which the bank
    solves in closed form as the underdamped pairs (``CoupledBank``).  The same bounds as the
    verified scenes: E <= 1e-8 at the default tolerance, 10x smaller at a 100x tighter one.
    Measured on FULL (9 elastic modes; 0, 2, 6, 7 of them overdamped at zeta = 0.2, 0.5, 1, 2):
    E 2.8e-13, 1.7e-15, 4.9e-15, 1.4e-15 at 1e-5 (16, 15, 12, 12 steps)."""
    scene = scene_with("damped", damping_ratio=zeta)
    prob = problem(FULL, scene)
    ref = run(prob, scene, method="dop853", rtol=1e-10, atol=1e-14)
    basis = exponential.linearise(prob.mass_matrix, prob.stiffness_diagonal, prob.damping_diagonal,
                                  prob.y0)
    m = basis.omega.size - exponential.N_JOINTS
    assert (basis.bank.mu.size > m) == overdamped, basis.bank.mu
    loose = run(prob, scene)
    tight = run(prob, scene, tol=exponential.DEFAULTS.tol / 100)
    E_loose, E_tight = E_max(ref, loose), E_max(ref, tight)
    assert E_loose <= 1e-8, (E_loose, loose.stats)
    assert E_tight <= max(0.1 * E_loose, 1e-13), (E_tight, E_loose)


def test_a_basis_with_more_real_eigenvalues_reallocates_the_loops_bank():
    """A new basis whose damped bank has another size (a mode past critical damping since the
    last one) gets bank and weight arrays of its size in the compiled loop's containers, the
    cache's count of computed weights kept."""
    light, heavy = (problem(FULL, scene_with("damped", damping_ratio=z)) for z in (0.2, 2.0))
    integrator = exponential.ExponentialAdams(light)
    integrator._new_basis(0.0, light.y0)
    m = light.y0.size - exponential.N_JOINTS
    assert integrator.kb.mu.size == m
    integrator.kw.used[2] = 5
    integrator.problem = heavy
    integrator._new_basis(1e-3, heavy.y0)
    bank = integrator.basis.bank
    assert integrator.kb.mu.size == bank.mu.size > m
    for name in ("mu", "P_eta", "P_vel", "V_eta", "V_vel", "phase_mode", "V_real"):
        np.testing.assert_array_equal(getattr(integrator.kb, name), getattr(bank, name))
    assert integrator.kw.E_re.shape[1] == bank.mu.size and integrator.kw.used[2] == 5


def test_free_scene_with_large_rates_relinearises_and_matches_dop853():
    """Case at rest, gimbals released at 10 rad/s: they turn by 0.15 rad, 15 x the drift
    that triggers a new basis.  Measured: 257 steps, 15 re-linearisations, E 1.1e-10."""
    scene, prob, ref = dop853_reference("stress_rates_10", "FULL")
    turn = np.max(np.abs(ref.y[:, :4] - ref.y[0, :4]))
    assert turn > 10 * exponential.DEFAULTS.drift
    r = run(prob, scene)
    assert r.stats["relinearisations"] >= turn / exponential.DEFAULTS.drift / 2, r.stats
    assert E_max(ref, r) <= 1e-8


# ------------------------------------------------------------- 4. order of accuracy
@functools.lru_cache(maxsize=None)
def fine_thesis_run():
    """(scene, problem, run at the fixed step 1e-5 s, order 4) of the SOFT chain in thesis."""
    scene = scenes.load_scene("thesis")
    prob = problem(SOFT, scene)
    return scene, prob, run(prob, scene, step=1e-5, order=4)


@pytest.mark.parametrize("order, least_slope", [(4, 3.5), (2, 2.5)])
def test_fixed_step_order_of_convergence(order, least_slope):
    """Fixed steps h, h/2, h/4 (6.4e-4 s down: h omega_max = 2.5, 1.2, 0.6), thesis scene,
    against a run at a 16x smaller step (order 4; itself 4e-15 from DOP853 at rtol 1e-12);
    the error is the largest gimbal-rate difference over the outputs, relative to the
    largest rate.  A predictor of order q with its corrector should converge at order q + 1.

    Measured (slope of the least-squares fit): order 4: 4.88 (errors 3.0e-7, 1.1e-8,
    3.4e-10); order 2: 2.99.  (Before the full-order block start of fixed-step runs,
    commit 1afdc9a, every order 2..6 gave 3.0: the order-1 first step dominated.)"""
    scene, prob, fine = fine_thesis_run()
    scale = np.max(np.abs(fine.yd[:, :4]))
    steps = np.array([6.4e-4, 3.2e-4, 1.6e-4])
    errors = []
    for h in steps:
        r = run(prob, scene, step=h, order=order)
        errors.append(np.max(np.abs(r.yd[:, :4] - fine.yd[:, :4])) / scale)
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert slope >= least_slope, f"observed order {slope:.2f}, errors {errors}"


# ---------------------------------------------------------------- 5. against RK4
def test_agrees_with_rk4_at_a_small_step():
    """Reduced synthetic model, thesis case motion, outputs every 1e-4 s so that RK4 runs at
    its own step (~4-5 % of its stability limit).  Measured: E(rk4 vs exponential) 9e-11,
    E(rk4 vs dop853) 1e-11."""
    scene = scene_with("thesis", output_interval=1e-4)
    prob = problem(REDUCED, scene)
    a = run(prob, scene, method="rk4", fraction=0.05)
    assert 0.03 < a.stats["fraction"] <= 0.05
    b = run(prob, scene)
    assert b.steps < a.steps / 5
    assert E_max(a, b) <= 1e-8


def test_rigid_chain_without_elastic_modes_matches_dop853():
    """No elastic coordinate (model 'rigid': the four joint angles only): no oscillator, no
    phase probe (a probe eigenproblem of size 0 once crashed the workflow's rigid simulation)."""
    scene = scenes.load_scene("thesis")
    prob = problem(dict(seed=3, omega_max=2e3, n_modes=(0, 0, 0, 0)), scene)
    assert prob.chain.n_coordinates == 4
    ref = run(prob, scene, method="dop853", rtol=1e-10, atol=1e-14)
    b = run(prob, scene)
    assert b.stats["relinearisations"] == 0
    assert E_max(ref, b) <= 1e-8


# ---------------------------------------------------------------- 6. bad input
class CountingProblem:
    """A problem whose every evaluation is counted (rhs, mass matrix, energies, ...)."""

    COUNTED = ("rhs", "mass_matrix", "residual", "solve", "kinetic_energy", "potential_energy",
               "energy", "input_power")

    def __init__(self, inner):
        self.inner = inner
        self.calls = 0

    def __getattr__(self, name):
        value = getattr(self.inner, name)
        if name in self.COUNTED:
            def counted(*args, **kwargs):
                self.calls += 1
                return value(*args, **kwargs)
            return counted
        return value


@pytest.fixture(scope="module")
def soft_thesis():
    scene = scenes.load_scene("thesis")
    return scene, problem(SOFT, scene)


@pytest.mark.parametrize("options", [
    dict(tol=0.0), dict(tol=-1e-6), dict(tol=float("nan")), dict(tol=float("inf")),
    dict(tol=1e-6, step=1e-4), dict(tol=1e-6, relinearise_every=1e-3),
    dict(relinearise_every=1e-3),                   # adaptive (default tol) with an interval
    dict(no_such_option=1), dict(rho_inf=0.9), dict(fraction=0.5), dict(rtol=1e-8),
    dict(order=0), dict(order=7), dict(order=2.5), dict(step=0.0), dict(step=float("nan")),
    dict(step=1e-4, relinearise_every=-1.0), dict(drift=0.0),
    dict(phase_tol=0.0), dict(grow_safety=float("nan")), dict(error_energy_weight=-1.0),
    dict(max_rejections=-1), dict(subdivisions=2.5), dict(weight_cache_entries=0),
], ids=lambda o: ",".join(f"{k}={v}" for k, v in o.items()))
def test_bad_exponential_options_refused_before_any_work(soft_thesis, options):
    scene, prob = soft_thesis
    counting = CountingProblem(prob)
    with pytest.raises(ValueError) as err:
        run(counting, scene, **options)
    message = str(err.value)
    assert message and "\n" not in message
    assert counting.calls == 0


def test_exponential_option_with_rk4_refused_before_any_work(soft_thesis):
    scene, prob = soft_thesis
    counting = CountingProblem(prob)
    for options in (dict(tol=1e-6), dict(relinearise_every=1e-3), dict(order=4), dict(drift=0.01),
                    dict(evaluate_accepted=True)):
        with pytest.raises(ValueError) as err:
            run(counting, scene, method="rk4", **options)
        assert "\n" not in str(err.value) and "exponential" in str(err.value)
    assert counting.calls == 0


# ------------------------------------------------------------- 7. failure modes
def drift_crossing(ref):
    """First output time [s] at which the gimbals are FROZEN_VALIDITY rad from the start."""
    drift = np.max(np.abs(ref.y[:, :4] - ref.y[0, :4]), axis=1)
    return float(ref.t[np.argmax(drift > exponential.DEFAULTS.frozen_validity)])


@pytest.mark.parametrize("options", [dict(relinearise=False), dict(step=1e-4, relinearise_every=1.0)],
                         ids=["adaptive, relinearise=False", "fixed step, interval > run"])
def test_frozen_basis_beyond_validity_is_refused(options):
    scene, prob, ref = dop853_reference("stress_rates_10", "FULL")
    t_cross = drift_crossing(ref)
    assert 0.1 * scene.duration < t_cross < 0.9 * scene.duration
    with pytest.raises(exponential.ExponentialError) as err:
        run(prob, scene, **options)
    message = str(err.value)
    assert "\n" not in message
    t_fail = time_in_message(message)
    # refused once the drift exceeds the validity, not before and not much after
    assert t_cross - 2 * scene.output_interval <= t_fail <= t_cross + 1e-3, (t_cross, message)


@pytest.mark.parametrize("options", [dict(relinearise=False), dict(step=1e-4)],
                         ids=["adaptive, relinearise=False", "fixed step, frozen"])
def test_frozen_basis_within_validity_runs_and_is_accurate(options):
    """The counterpart: the same scene ended before the drift reaches FROZEN_VALIDITY."""
    long_scene, prob, ref = dop853_reference("stress_rates_10", "FULL")
    t_cross = drift_crossing(ref)
    k = int(0.8 * t_cross / long_scene.output_interval)
    scene = scene_with("stress_rates_10", duration=k * long_scene.output_interval)
    r = run(prob, scene, **options)
    assert r.t.size == k + 1 and r.stats["relinearisations"] == 0
    E = error_measure(r.t, ref.yd[:k + 1, :4], r.yd[:, :4])
    assert np.max(E) <= 1e-8, E


@pytest.mark.parametrize("options, t_bad", [
    (dict(), 0.00731), (dict(step=1e-4), 0.00731),
    (dict(step=1e-4), 2.5e-4),        # inside the start-up block (the first 4 steps)
], ids=["adaptive", "fixed step", "fixed step, in the start-up block"])
def test_non_finite_rhs_stops_with_the_time(soft_thesis, options, t_bad):
    """The right-hand side turns NaN from t_bad on: the run stops with ExponentialError
    naming a time within a step of t_bad (measured: adaptive 0.00731 s, fixed 0.0074 s;
    in the start-up block the message names t = 0 s although the first NaN is at 3e-4 s)."""
    scene, prob = soft_thesis
    original = prob.rhs
    broken = copy.copy(prob)
    broken.rhs = lambda t, y, yd: original(t, y, yd) if t < t_bad else np.full(y.size, np.nan)
    with pytest.raises(exponential.ExponentialError) as err:
        run(broken, scene, **options)
    message = str(err.value)
    assert "\n" not in message
    t_fail = time_in_message(message)
    assert t_bad - scene.output_interval <= t_fail <= t_bad + options.get("step", 0.0) + 1e-9, message


# ------------------------------------------------------------ 8. energy conservation
def energy(prob, r):
    """T + U [in lbf] at every output of run r."""
    return np.array([prob.kinetic_energy(t, y, v) + prob.potential_energy(y)
                     for t, y, v in zip(r.t, r.y, r.yd)])


def test_free_scene_conserves_energy_over_many_steps():
    """Case at rest, no torques, undamped, initial rates 0.3 rad/s, 2 s: the gimbals turn
    by 0.57 rad.  Measured at the default tol (1e-5): 996 steps, 1008
    evaluations, 62 bases, relative drift of T + U 2.4e-6 (with a final evaluation per step,
    PECE: 1060 steps, 2130 evaluations, 3.5e-6)."""
    scene = scene_with("free", duration=2.0, output_interval=1e-3)
    prob = problem(SOFT, scene)
    r = run(prob, scene)
    assert r.steps > 500 and r.stats["relinearisations"] > 10
    E = energy(prob, r)
    drift = np.max(np.abs(E - E[0])) / E[0]
    assert drift <= exponential.DEFAULTS.tol, drift


def test_free_scene_with_elastic_energy_conserves_energy():
    """As above with initial elastic deflections holding 17 % of the energy (the fast modes
    carry energy), 0.1 s.  Measured: drift 1e-6 at the default tol."""
    scene = scene_with("free", duration=0.1, output_interval=1e-3)
    prob = problem(SOFT, scene)
    rng = np.random.default_rng(0)
    q = rng.normal(size=prob.y0.size - 4)
    T0 = prob.kinetic_energy(0.0, prob.y0, prob.yd0)
    q *= math.sqrt(0.2 * T0 / (0.5 * np.dot(prob.stiffness_diagonal[4:] * q, q)))
    y0 = prob.y0.copy()
    y0[4:] = q
    r = integrators.integrate(prob, scene.duration, scene.output_interval, method="exponential",
                              y0=y0)
    E = energy(prob, r)
    assert prob.potential_energy(r.y[0]) > 0.1 * E[0]
    drift = np.max(np.abs(E - E[0])) / E[0]
    assert drift <= exponential.DEFAULTS.tol, drift


def test_modal_states_rows_and_functionals_per_segment():
    """ModalStates builds row k as offset_s + phi_s eta_k with s its segment, whatever the order
    of the segments (grouped by one sort), for a block of rows and columns, the whole array and
    linear functionals L y; a row read with another segment's basis would differ by O(1)."""
    from gimbal_reduction.solver.dynamics.exponential import ModalStates
    rng = np.random.default_rng(3)
    T, n = 9, 5
    eta = rng.standard_normal((T, n))
    segment = np.array([0, 0, 2, 1, 1, 2, 0, 2, 1])
    offsets = [rng.standard_normal(n) for _ in range(3)]
    phis = [rng.standard_normal((n, n)) for _ in range(3)]
    direct = np.array([offsets[s] + phis[s] @ eta[k] for k, s in enumerate(segment)])
    states = ModalStates(eta, segment, offsets, phis)
    np.testing.assert_allclose(states[1:7, 1:3], direct[1:7, 1:3], rtol=0, atol=1e-13)
    L = rng.standard_normal((2, n))
    np.testing.assert_allclose(states.functionals(L), direct @ L.T, rtol=0, atol=1e-13)
    np.testing.assert_allclose(np.asarray(states), direct, rtol=0, atol=1e-13)
    np.testing.assert_allclose(states.functionals(L), direct @ L.T, rtol=0, atol=1e-13)   # from full
    wrong = ModalStates(eta, np.roll(segment, 1), offsets, phis)
    assert np.abs(np.asarray(wrong) - direct).max() > 0.1

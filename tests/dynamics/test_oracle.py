"""The key test: the fast equations against an independent oracle.

The oracle (results/bench/oracle.Oracle) differentiates, with JAX, the
Lagrangian written directly from nodal masses and nodal kinematics of small
synthetic bodies; the fast model (gimbal_reduction.solver.dynamics.multibody) uses only modal
integrals and a recursive Newton-Euler / articulated-body formulation.
At random states they must agree to 1e-10 relative.
"""

import numpy as np
import pytest

from gimbal_reduction.solver.dynamics import checks as dynamics_checks, multibody
from gimbal_reduction.results.bench.oracle import Oracle, jax_available, synthetic_chain

pytestmark = pytest.mark.skipif(
    not jax_available(),
    reason="JAX not installed (run workflow/envs/install.sh; tests with .venv/bin/python -m pytest)")

TOL = 1e-10


def random_state(rng, chain, q_scale=0.02):
    n = chain.n_coordinates
    y = np.concatenate([rng.uniform(-np.pi, np.pi, 4), q_scale * rng.normal(size=n - 4)])
    yd = np.concatenate([rng.normal(size=4), 20 * q_scale * rng.normal(size=n - 4)])
    return y, yd


@pytest.fixture(scope="module")
def damped_case():
    """Chain with shells (rotation DOFs), consistent and lumped mass, damping, a case
    rotating about a skew axis with harmonic acceleration."""
    chain, datas = synthetic_chain(seed=3, n_modes=(3, 2, 2, 2), damping_ratio=0.02)
    oracle = Oracle(datas, axis=(0.3, -0.5, 0.8), amp=1.3, freq=2.0, phase=0.4, omega0=0.7,
                    damping_ratio=0.02)
    return chain, oracle


def test_mass_matrix_and_force_match_oracle(damped_case):
    chain, oracle = damped_case
    case = oracle.case_motion()
    rng = np.random.default_rng(11)
    torque = np.array([0.3, -0.2, 0.1, 0.05])
    results = []
    for trial in range(3):
        y, yd = random_state(rng, chain)
        t = rng.uniform(0, 1)
        Mo, fo = oracle.equations(y, yd, t, torque)
        Mf = multibody.mass_matrix(chain, y)
        ff = multibody.generalized_force(chain, y, yd, t, case, torque)
        results += dynamics_checks.oracle_agreement(f"random state {trial}", Mf, ff, Mo, fo, TOL)
        # the fast right-hand side (articulated-body solve) gives M^-1 f
        a = multibody.accelerations(chain, y, yd, t, case, torque)
        results.append(dynamics_checks.check(
            f"random state {trial}: accelerations vs oracle",
            dynamics_checks.relative_difference(a, np.linalg.solve(Mo, fo)), TOL))
    for r in results:
        assert r["passed"], f"{r['name']}: {r['value']:.2e} > {r['tolerance']:.0e}"


def test_generalized_momentum_matches_oracle(damped_case):
    chain, oracle = damped_case
    rng = np.random.default_rng(12)
    y, yd = random_state(rng, chain)
    p_fast = multibody.generalized_momentum(chain, y, yd, 0.2, oracle.case_motion())
    p_oracle = oracle.momentum(y, yd, 0.2)
    assert dynamics_checks.relative_difference(p_fast, p_oracle) < TOL


def test_large_elastic_coordinates_still_exact(damped_case):
    """The kinematics (Euler-angle inside-frame rotation, first-order body energy) are
    exact for the model's Lagrangian at any size of q, so agreement does not rest on q
    being small."""
    chain, oracle = damped_case
    rng = np.random.default_rng(13)
    y, yd = random_state(rng, chain, q_scale=0.5)
    Mo, fo = oracle.equations(y, yd, 0.05)
    Mf = multibody.mass_matrix(chain, y)
    ff = multibody.generalized_force(chain, y, yd, 0.05, oracle.case_motion())
    for r in dynamics_checks.oracle_agreement("large q", Mf, ff, Mo, fo, TOL):
        assert r["passed"], f"{r['name']}: {r['value']:.2e}"


def test_rotation_blocks_fixed_in_body_axes_variant():
    """The alternative treatment of rotation DOF blocks (frame rotation on translation
    blocks only) is also exactly what its oracle says."""
    from gimbal_reduction.results.bench.oracle import chain_body, synthetic_body
    rng = np.random.default_rng(21)
    datas = [synthetic_body(rng, n, n_modes=2, rotations=True, consistent=(n % 2 == 0))
             for n in (2, 3, 4, 5)]
    chain = multibody.Chain(tuple(chain_body(d, rotate_rotation_blocks=False) for d in datas))
    oracle = Oracle(datas, axis=(1.0, 0.2, 0.0), amp=0.8, freq=1.0, rotate_rotation_blocks=False)
    y, yd = random_state(rng, chain)
    Mo, fo = oracle.equations(y, yd, 0.3)
    Mf = multibody.mass_matrix(chain, y)
    ff = multibody.generalized_force(chain, y, yd, 0.3, oracle.case_motion())
    for r in dynamics_checks.oracle_agreement("translation-only", Mf, ff, Mo, fo, TOL):
        assert r["passed"], f"{r['name']}: {r['value']:.2e}"


def test_platform_attitude_matches_the_oracles_poses(damped_case):
    """multibody.platform_attitude (joint rotations and the parents' bearing rotations Theta q)
    against the oracle's independent poses (inside frames solved from the bearing operator on
    the nodal displacements): the platform's axes in case axes, A_case^T A_platform."""
    chain, oracle = damped_case
    rng = np.random.default_rng(11)
    n = chain.n_coordinates
    Y = np.zeros((4, n))
    Y[:, :4] = rng.uniform(-2.5, 2.5, (4, 4))
    Y[:, 4:] = 0.05 * rng.standard_normal((4, n - 4))
    R = multibody.platform_attitude(chain, Y)
    t = 0.37
    A_case = np.asarray(oracle._axis_rotation(oracle._case_angle(t)))
    for k in range(4):
        A_platform = np.asarray(oracle.poses(Y[k], t)[3][0])
        assert np.abs(A_case.T @ A_platform - R[k]).max() < 1e-12
    # the attitude error of two histories is the angle between them (here: a known rotation)
    from gimbal_reduction.solver.dynamics.error_measure import attitude_error
    turn = multibody._rotations(2, np.array([1e-6, 0.3, 2.0]))
    angle = attitude_error(R[:3], R[:3] @ turn)
    assert np.allclose(angle, [1e-6, 0.3, 2.0], rtol=1e-9, atol=1e-15)

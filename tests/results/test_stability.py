"""Numerical stability stress tests (results/bench/{rk4_theory,chain_stability,hard_cases,stability}.py,
issue 6) on small synthetic chains, plus one measurement on the real bodies (skipped when the FE and
reduction stages have not run).

Each test checks a measured number against theory, so it fails if the bisection, the
excitation, the drift measure or the hard-case judgement is wrong.
"""

import numpy as np
import pytest

from gimbal_reduction.results.bench import chain_stability, hard_cases, rk4_theory, stability
from gimbal_reduction.solver.dynamics import integrators, linearized, multibody, scenes
from gimbal_reduction.solver.dynamics.problem import Problem
from gimbal_reduction.reduction import models
from gimbal_reduction.results.bench.oracle import synthetic_chain
from tests.dynamics_fixtures import load_real_bodies
from tests.dynamics_fixtures import real_bodies_only as real_only


# ------------------------------------------------------------------ RK4 theory, bisection
def test_rk4_bounds_from_the_amplification_factor():
    """2 sqrt 2 on the imaginary axis (x^2 = 8 from 1 - x^6/72 + x^8/576 = 1); on the real
    axis the real root of x^3 - 4x^2 + 12x - 24, of which the project's 2.785 is the rounding."""
    assert rk4_theory.rk4_imaginary_axis_limit() == pytest.approx(2 * np.sqrt(2), rel=1e-13)
    x = rk4_theory.rk4_imaginary_axis_limit()
    assert abs(rk4_theory.rk4_amplification(1j * x)) ** 2 == pytest.approx(1 - x ** 6 / 72 + x ** 8 / 576, abs=1e-14)
    roots = np.roots([1.0, -4.0, 12.0, -24.0])
    real_root = float(roots[np.abs(roots.imag) < 1e-12].real[0])
    assert rk4_theory.rk4_real_axis_limit() == pytest.approx(real_root, rel=1e-12)
    assert abs(rk4_theory.rk4_real_axis_limit() - integrators.RK4_STABILITY) < 5e-4


def test_bisection_on_a_scalar_oscillator_finds_2_sqrt_2():
    """RK4 on x'' = -omega^2 x: the energy ratio is |R(i h omega)|^(2n) exactly, so the measured
    limit sits above 2 sqrt 2 / omega by ln(10) / (14.2 n) = 8.1e-5 for n = 2000 steps, and well
    above the real-axis 2.785 (which a wrong growth test or bracket would find)."""
    omega = 50.0
    res = rk4_theory.oscillator_rk4_limit(omega, n_steps=2000)
    x = res["step"] * omega
    assert 0.0 < x / (2 * np.sqrt(2)) - 1.0 < 2e-4
    assert x > 2.81
    h = res["step"]
    below, above = (rk4_theory.oscillator_energy_ratio(omega, f * h, 2000) for f in (0.999, 1.001))
    assert below < 1.0 < above


def test_bisection_logic_and_bad_brackets():
    res = rk4_theory.bisect_stability_limit(lambda h: h <= 0.3, 0.1, 1.0, rtol=1e-6)
    assert res["lo"] <= 0.3 < res["hi"] and res["hi"] - res["lo"] <= 1e-6 * res["lo"]
    assert all(s == (h <= 0.3) for h, s in res["trials"])
    for lo, hi, message in ((0.4, 1.0, "already unstable"), (0.1, 0.2, "still stable"),
                            (1.0, 0.1, "0 < h_stable < h_unstable")):
        with pytest.raises(rk4_theory.StabilityInputError, match=message) as exc:
            rk4_theory.bisect_stability_limit(lambda h: h <= 0.3, lo, hi)
        assert "\n" not in str(exc.value)


# ------------------------------------------------------------------ coupled modes, excitation
def test_coupled_modes_are_mass_orthonormal_eigenvectors_of_the_full_pencil():
    chain, _ = synthetic_chain(seed=4)
    y = np.zeros(chain.n_coordinates)
    y[:4] = chain_stability.THESIS_ANGLES
    M = multibody.mass_matrix(chain, y)
    K = np.diag(chain.stiffness_diagonal())
    omega, phi = linearized.free_joint_modes(M, chain.stiffness_diagonal()[4:])
    np.testing.assert_allclose(omega, linearized.coupled_frequencies(chain, y), rtol=1e-8)
    omega_y, phi_y = linearized.coupled_modes(chain, y)          # M(y) by the compiled columns
    np.testing.assert_allclose(omega_y, omega, rtol=1e-8)
    np.testing.assert_allclose(phi.T @ M @ phi, np.eye(omega.size), atol=1e-9)
    np.testing.assert_allclose(K @ phi, M @ phi * omega ** 2, atol=1e-8 * omega.max() ** 2)
    np.testing.assert_allclose((M @ phi)[:4], 0.0, atol=1e-12)   # no joint momentum
    with pytest.raises(ValueError, match="do not match"):
        linearized.free_joint_modes(M, chain.stiffness_diagonal())


def test_equal_energy_excitation_puts_the_requested_energy_in_every_mode():
    chain, _ = synthetic_chain(seed=4)
    y0, yd0, omega, M = chain_stability.excited_state(chain, energy=2e-6)
    assert multibody.kinetic_energy(chain, y0, yd0) == pytest.approx(2e-6, rel=1e-9)
    _, phi = linearized.free_joint_modes(M, chain.stiffness_diagonal()[4:])
    per_mode = 0.5 * (phi.T @ M @ yd0) ** 2
    np.testing.assert_allclose(per_mode, 2e-6 / omega.size, rtol=1e-8)


# ------------------------------------------------------------------ measured limits
def test_measured_rk4_limit_of_a_synthetic_chain_matches_theory():
    """Bisection on the step of the coupled chain: within 5 % of 2.785/omega_max (the check
    of the CLI), and within 0.1 % of the undamped bound 2 sqrt 2 / omega_top."""
    chain, _ = synthetic_chain(seed=0)
    res = chain_stability.measure_chain_rk4_limit(chain, n_steps=2000, rtol=5e-4)
    assert abs(res["ratio_bound"] - 1.0) < stability.LIMIT_TOLERANCE
    assert abs(res["ratio_imaginary"] - 1.0) < 1e-3
    assert res["omega_top"] > 1.2 * res["modal_omega_max"]      # the coupled frequency, not the kept one
    assert res["h_lo"] < res["h_measured"] < res["h_hi"]


def test_energy_growth_flags_an_unstable_step_and_not_a_stable_one():
    chain, _ = synthetic_chain(seed=0)
    y0, yd0, omega, _ = chain_stability.excited_state(chain)
    prob = Problem(chain, y0=y0, yd0=yd0)
    h_star = 2 * np.sqrt(2) / omega[-1]
    assert chain_stability.energy_growth(prob, y0, yd0, 0.98 * h_star, 1000) <= 1.0 + 1e-9
    assert chain_stability.energy_growth(prob, y0, yd0, 1.05 * h_star, 1000) > 10.0


# ------------------------------------------------------------------ energy drift
def test_relative_energy_drift_definition():
    T = np.array([2.0, 2.5, 1.0])
    U = np.array([1.0, 0.5, 2.5])
    W = np.array([0.0, 0.0, 0.3])
    np.testing.assert_allclose(chain_stability.relative_energy_drift(T, U), [0.0, 0.0, 0.5 / 3.0])
    np.testing.assert_allclose(chain_stability.relative_energy_drift(T, U, W), [0.0, 0.0, 0.2 / 3.0])
    with pytest.raises(rk4_theory.StabilityInputError):
        chain_stability.relative_energy_drift(T, U, W[:2])


def test_rk4_energy_drift_on_a_free_synthetic_chain_is_small():
    """Scene free (case at rest) with realistic frequency separation: RK4 at its default
    step (half its stability limit) conserves E to far better than 1e-9 over 15 ms."""
    chain, _ = synthetic_chain(seed=1, omega_max=2e4)
    res = chain_stability.drift_run(chain, scenes.load_scene("free"), "rk4")
    assert res["drift"][0] == 0.0 and res["drift_max"] < 1e-9
    assert res["drift"].size == 1501 and res["steps"] >= 1500


def test_generalized_alpha_drift_reported_for_a_large_step():
    chain, _ = synthetic_chain(seed=1, omega_max=2e4)
    res = chain_stability.drift_run(chain, scenes.load_scene("free"), "generalized-alpha", step=1e-4)
    assert np.isfinite(res["drift_max"]) and res["drift_max"] < 1e-6
    assert res["options"] == {"step": 1e-4}


# ------------------------------------------------------------------ hard cases
def test_100_rad_s_is_verified_or_diagnosed():
    chain, _ = synthetic_chain(seed=3, omega_max=2e3)
    res = hard_cases.checked_run(chain, scenes.load_scene("stress_rates_100"), "synthetic")
    assert res["outcome"] in ("verified", "diagnosed")
    assert hard_cases.case_passes(res)
    if res["outcome"] == "verified":
        assert res["E_max"] <= hard_cases.HARD_CASE_TOLERANCE and res["max_rate"] >= 100.0
        assert res["energy_balance"] < 1e-6


def test_unstable_step_is_diagnosed_in_one_line_and_a_disagreeing_run_is_garbage():
    chain, _ = synthetic_chain(seed=3, omega_max=2e3)
    thesis = scenes.load_scene("thesis")
    y0 = np.zeros(chain.n_coordinates)
    y0[:4] = thesis.initial_angles
    # omega_max understated by 2x (below even the largest kept modal frequency): the default
    # step is beyond the true limit (the output interval must not cap it)
    coarse = hard_cases.scene_variant(thesis, "coarse", duration=0.1, output_interval=5e-3)
    prob = Problem(chain, case=thesis.case, y0=y0, omega_max=0.5 * chain.omega_max)
    res = hard_cases.checked_run(chain, coarse, "synthetic", problem=prob)
    assert res["outcome"] == "diagnosed" and res["error"] == "DivergenceError"
    assert hard_cases.is_one_line_diagnosis(res["message"], "'synthetic'", "t = ", "step")
    assert hard_cases.case_passes(res) and hard_cases.case_passes(res, expect="diagnosed")
    assert not hard_cases.case_passes(res, expect="verified")
    # a tolerance no run can meet turns a finished run into garbage: the judgement can fail
    short = hard_cases.scene_variant(thesis, "short", duration=0.002)
    bad = hard_cases.checked_run(chain, short, "synthetic", tol=0.0)
    assert bad["outcome"] == "garbage" and not hard_cases.case_passes(bad)
    refused = hard_cases.checked_run(chain, short, "synthetic", fraction=1.3)
    assert refused["error"] == "StepTooLargeError" and hard_cases.case_passes(refused, expect="diagnosed")


def test_rate_error_zero_columns_and_resonance_growth():
    t = np.linspace(0.0, 1.0, 11)
    ref = np.column_stack([np.sin(t), np.zeros_like(t), t, np.zeros_like(t)])
    cand = ref.copy()
    cand[:, 2] *= 1.001
    cand[:, 3] = 1e-3
    E = hard_cases.rate_error(ref, cand, t)
    assert E[0] == 0.0 and E[1] == 0.0 and E[2] == pytest.approx(1e-6) and np.isinf(E[3])

    class FakeRun:
        energy = {"potential": (np.linspace(0.0, 1.0, 101)) ** 2}
    g = hard_cases.potential_growth(FakeRun())
    assert g["potential_growth"] == pytest.approx(25.0, rel=1e-9)   # amplitude linear in t: (1/0.2)^2


# ------------------------------------------------------------------ gimbal lock
def test_drive_axes_match_the_chain_kinematics_and_locate_gimbal_lock():
    chain, _ = synthetic_chain(seed=2)
    ang = np.array([0.3, -0.7, 1.1, 0.5])
    y = np.zeros(chain.n_coordinates)
    y[:4] = ang
    A = np.eye(3)
    expected = []
    for j in range(1, 5):
        A = A @ multibody.joint_state(chain, j, y, np.zeros_like(y)).R
        expected.append(A[:, 0])
    np.testing.assert_allclose(chain_stability.drive_axes(ang), np.array(expected), atol=1e-14)
    # thesis configuration: x_3 and x_5 antiparallel, yet the four axes span space
    thesis_axes = chain_stability.drive_axes(chain_stability.THESIS_ANGLES)
    assert chain_stability.axis_alignment(thesis_axes) < 1e-12 and chain_stability.lock_distance(thesis_axes) > 0.99
    # gamma_2 = gamma_3 = 0: all four axes in one plane; 1e-3 from it: distance ~1e-3
    assert chain_stability.lock_distance(chain_stability.drive_axes([0.2, 0.0, 0.0, -0.4])) < 1e-14
    assert chain_stability.lock_distance(chain_stability.drive_axes([0.0, 1e-3, 1e-3, 0.0])) == pytest.approx(1e-3, rel=1e-3)
    with pytest.raises(rk4_theory.StabilityInputError, match="4 gimbal angles"):
        chain_stability.drive_axes([0.0, 0.0])


def test_mass_matrix_stays_well_conditioned_at_gimbal_lock():
    """Lock is a kinematic singularity of the platform's orientation, not of M(y): every
    joint still moves its own subtree's inertia, so M_gg stays invertible."""
    chain, _ = synthetic_chain(seed=2)
    y = np.zeros(chain.n_coordinates)
    y[:4] = [0.0, 0.0, 0.0, 0.0]
    c = chain_stability.mass_conditioning(multibody.mass_matrix(chain, y))
    assert np.isfinite(c["cond_M"]) and c["cond_joints"] < 1e4 and c["min_eig_schur"] > 0


# ------------------------------------------------------------------ scenes, CLI
def test_stress_scenes_load_and_variants_are_validated():
    for name, rates in (("stress_rates_10", 10.0), ("stress_rates_100", 100.0)):
        sc = scenes.load_scene(name)
        assert np.max(np.abs(sc.initial_rates)) == rates and sc.case.at_rest
    lock = scenes.load_scene("stress_lock")
    assert chain_stability.lock_distance(chain_stability.drive_axes(lock.initial_angles)) < 2e-3
    long = scenes.load_scene("free_10s")
    assert long.duration == 10.0 and long.case.at_rest
    v = hard_cases.scene_variant(long, "v", duration=1.0, case_angular_acceleration_frequency=[5.0, 0.0, 0.0])
    assert v.duration == 1.0 and v.case.frequency == (5.0, 0.0, 0.0) and long.duration == 10.0
    with pytest.raises(scenes.SceneError, match="duration"):
        hard_cases.scene_variant(long, "bad", duration=-1.0)


def test_cli_missing_inputs_one_line(tmp_path, capsys):
    rc = stability.main(["--bodies", *[str(tmp_path / f"body{b}.h5") for b in (2, 3, 4, 5)],
                         "--reductions", *[str(tmp_path / f"red{b}.h5") for b in (2, 3, 4, 5)],
                  "--out-dir", str(tmp_path / "out"), "--figures-dir", str(tmp_path / "fig")])
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "missing" in err[0]
    assert not (tmp_path / "out").exists()


@real_only
def test_real_freq5_rk4_limit_within_5_percent_and_old_bound_diagnosed():
    rankings, data = load_real_bodies()
    chain = models.build_chain(models.model_spec("freq-5", rankings), data)
    res = chain_stability.measure_chain_rk4_limit(chain, n_steps=1500, rtol=1e-3)
    assert abs(res["ratio_bound"] - 1.0) < stability.LIMIT_TOLERANCE
    assert abs(res["ratio_imaginary"] - 1.0) < 2e-3

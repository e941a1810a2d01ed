"""gimbal_reduction.reduction.frequency_error against independent forms: the inverse dynamics and the
platform attitude it linearises, python-control's state-space frequency response of the whole
chain, a dense direct frequency sweep, and the closed-form H2 norm of an oscillator."""
from dataclasses import replace

import control
import numpy as np
import pytest

from gimbal_reduction.reduction import frequency_error as fe
from gimbal_reduction.solver.dynamics import error_measure, multibody, scenes
from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain

ZETA = 0.01
ANGLES = np.array([0.3, -1.2, 0.7, -0.4])          # rad: a general configuration (no axis aligned)


def chain_and_y0(n_modes=3, seed=1):
    chain = synthetic_modal_chain(n_modes, seed=seed)
    y0 = np.zeros(chain.n_coordinates)
    y0[:4] = ANGLES
    return chain, y0


def lin_of(chain, angles=ANGLES):
    """The chain linearised at the gimbal angles ``angles``, elastic coordinates 0."""
    y0 = np.zeros(chain.n_coordinates)
    y0[:4] = angles
    return fe.linear_chain(chain, y0)


def without_modes(chain, drop):
    """The chain without the modes drop = {body index 0..3: local indices}: a reduced model whose
    modes are a subset of the truth's (its integrals are the truth's restricted to them)."""
    bodies = []
    for k, b in enumerate(chain.bodies):
        keep = np.setdiff1d(np.arange(b.n_modes), drop.get(k, []))
        inside = {} if b.inside_translation is None else {
            "inside_translation": b.inside_translation[:, keep], "inside_rotation": b.inside_rotation[:, keep]}
        bodies.append(replace(b, momentum=b.momentum[:, keep], inertia_gradient=b.inertia_gradient[keep],
                              coriolis=b.coriolis[keep][:, :, keep], omega2=b.omega2[keep],
                              damping=b.damping[keep], labels=(), **inside))
    return replace(chain, bodies=tuple(bodies))


def full_state_space(lin, zeta):
    """python-control state space of the whole linear chain, rigid part included:
    x'' = M^-1 (B u - D x' - K x), y = C x'."""
    n = lin.M.shape[0]
    D = fe.coupled_damping(lin, zeta)
    Minv = np.linalg.inv(lin.M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ np.diag(lin.stiffness), -Minv @ D]])
    return control.ss(A, np.vstack([np.zeros((n, fe.N_INPUTS)), Minv @ lin.B]),
                      np.hstack([np.zeros((fe.N_OUTPUTS, n)), lin.C]), np.zeros((fe.N_OUTPUTS, fe.N_INPUTS)))


def dense_sweep(lin, zeta, omega, chunk=4000):
    """G(i w) (F, 7, 7) of the whole chain by batched dense solves of (K - w^2 M + i w D) (rigid
    part included), independent of the modal form."""
    D = fe.coupled_damping(lin, zeta)
    K = np.diag(lin.stiffness)
    out = []
    for w in np.array_split(omega, max(1, omega.size // chunk)):
        Z = K[None] - (w ** 2)[:, None, None] * lin.M[None] + (1j * w)[:, None, None] * D[None]
        out.append((1j * w)[:, None, None] * (lin.C[None] @ np.linalg.solve(Z, lin.B[None])))
    return np.concatenate(out)


# ------------------------------------------------------------ the linearisation
def test_mass_and_input_matrices_are_those_of_the_numpy_inverse_dynamics():
    chain, y0 = chain_and_y0()
    lin = fe.linear_chain(chain, y0)
    M = multibody.mass_matrix(chain, y0)
    np.testing.assert_allclose(lin.M, M, rtol=0, atol=1e-12 * np.abs(M).max())
    zero = np.zeros(chain.n_coordinates)
    for k in range(3):     # a unit case acceleration about axis k, at rest: -ID = B[:, k]
        case = multibody.CaseMotion(amplitude=tuple(float(i == k) for i in range(3)))
        ref = -multibody.inverse_dynamics(chain, y0, zero, zero, 0.0, case)
        np.testing.assert_allclose(lin.B[:, k], ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    assert np.array_equal(lin.B[:4, 3:], np.eye(4)) and not lin.B[4:, 3:].any()


def test_attitude_rows_are_the_derivative_of_the_platform_attitude():
    chain, y0 = chain_and_y0()
    A = fe.attitude_rate_matrix(chain, y0)
    R0 = multibody.platform_attitude(chain, y0[None])[0]
    h = 1e-6
    for i in range(chain.n_coordinates):
        e = np.zeros_like(y0)
        e[i] = h
        dR = (multibody.platform_attitude(chain, (y0 + e)[None])[0]
              - multibody.platform_attitude(chain, (y0 - e)[None])[0]) / (2 * h)
        W = R0.T @ dR                                   # skew(omega) in platform axes
        np.testing.assert_allclose(W, -W.T, atol=1e-8 * max(1.0, np.abs(W).max()))
        np.testing.assert_allclose(A[:, i], [W[2, 1], W[0, 2], W[1, 0]], rtol=1e-7, atol=1e-8)
    # the platform's own modes do not move its frame
    assert not A[:, chain.slices[3]].any()


# ------------------------------------------------------------ the transfer
def test_modal_transfer_is_the_whole_chains_state_space_without_its_rigid_part():
    chain, y0 = chain_and_y0()
    lin = fe.linear_chain(chain, y0)
    modal = fe.ModalTransfer(lin, ZETA)
    omega = np.geomspace(0.3 * modal.omega[0], 2.0 * modal.omega[-1], 40)
    omega = np.sort(np.concatenate([omega, modal.omega * np.sqrt(1 - ZETA ** 2)]))   # peaks too
    resp = full_state_space(lin, ZETA).frequency_response(omega)     # (sorts omega)
    assert np.array_equal(resp.omega, omega)
    G_ss = np.moveaxis(np.asarray(resp.complex), -1, 0)                                # (F, 7, 7)
    elastic = G_ss - fe.rigid_gain(lin)[None] / (1j * omega)[:, None, None]
    got = modal(omega)
    scale = np.abs(got).max(axis=(1, 2))
    assert np.all(np.abs(got - elastic).max(axis=(1, 2)) <= 1e-7 * scale)
    # and the direct solve of the module agrees with the dense batched one
    np.testing.assert_allclose(fe.transfer_direct(lin.M, fe.coupled_damping(lin, ZETA), np.diag(lin.stiffness),
                                                  lin.B, lin.C, omega[:5]),
                               dense_sweep(lin, ZETA, omega[:5]), rtol=1e-9)


def test_rigid_chain_has_no_elastic_transfer_and_the_same_rigid_part():
    chain, y0 = chain_and_y0()
    rigid = lin_of(without_modes(chain, {k: range(3) for k in range(4)}))
    truth = fe.linear_chain(chain, y0)
    fe.check_same_rigid(truth, rigid)
    np.testing.assert_allclose(fe.rigid_gain(rigid), fe.rigid_gain(truth), rtol=1e-12, atol=1e-15)
    assert not fe.ModalTransfer(rigid, ZETA)(np.array([1.0, 1e4])).any()
    # another configuration is another rigid chain: refused
    y1 = y0.copy()
    y1[1] += 0.3
    with pytest.raises(fe.FrequencyError, match="rigid chain"):
        fe.check_same_rigid(truth, fe.linear_chain(chain, y1), "moved")


# ------------------------------------------------------------ the norms
@pytest.mark.parametrize("zeta", [0.01, 0.05])
def test_h2_of_an_oscillator_is_its_closed_form(zeta):
    # G = 1 / (s^2 + 2 zeta w s + w^2): ||G||_H2^2 = 1 / (4 zeta w^3)
    w0 = 2.0e3
    opts = fe.FrequencyErrorOptions(damping_floor=zeta)
    grid = fe.frequency_grid(w0 * 1e-3, w0 * 1e3, [(np.array([w0 * np.sqrt(1 - zeta ** 2)]),
                                                    np.array([zeta * w0]))], opts)
    G = fe.transfer_direct(np.eye(1), 2 * zeta * w0 * np.eye(1), w0 ** 2 * np.eye(1), np.eye(1),
                           np.eye(1), grid, velocity=False)
    assert fe.band_h2(G, grid) ** 2 == pytest.approx(1.0 / (4 * zeta * w0 ** 3), rel=1e-3)
    # and its H-infinity norm 1 / (2 zeta sqrt(1 - zeta^2) w^2), at the peak the grid holds
    assert np.max(fe.sigma_max(G)) == pytest.approx(1 / (2 * zeta * np.sqrt(1 - zeta ** 2) * w0 ** 2), rel=1e-3)


def band_of(lin, top):
    modal = fe.ModalTransfer(lin, ZETA)
    return modal, fe.make_band(modal, fe.input_weights(lin), top, 0, fe.FrequencyErrorOptions())


def test_truth_against_itself_is_zero_and_a_missing_in_band_mode_is_not():
    chain, y0 = chain_and_y0()
    truth = fe.linear_chain(chain, y0)
    modal, band = band_of(truth, 1.2e5)
    W = fe.input_weights(truth)
    opts = fe.FrequencyErrorOptions()
    same = fe.model_error(band, modal, fe.ModalTransfer(truth, ZETA), W, opts)
    assert same["hinf"] == 0.0 and same["h2"] == 0.0
    # without the outer gimbal's lowest mode (in band): the truth's resonance is missing
    model = lin_of(without_modes(chain, {0: [0]}))
    err = fe.model_error(band, modal, fe.ModalTransfer(model, ZETA), W, opts)
    assert err["hinf"] > 0.1 and err["h2"] > 0.01
    # the rigid chain misses all of it: exactly 1
    rigid = lin_of(without_modes(chain, {k: range(3) for k in range(4)}))
    err = fe.model_error(band, modal, fe.ModalTransfer(rigid, ZETA), W, opts)
    assert err["hinf"] == pytest.approx(1.0, rel=1e-9) and err["h2"] == pytest.approx(1.0, rel=1e-12)


def test_hinf_and_h2_match_a_dense_direct_sweep():
    chain, y0 = chain_and_y0(n_modes=2, seed=3)
    truth = fe.linear_chain(chain, y0)
    model = lin_of(without_modes(chain, {1: [1], 3: [0]}))
    modal_t, band = band_of(truth, 3.0e4)
    err = fe.model_error(band, modal_t, fe.ModalTransfer(model, ZETA), fe.input_weights(truth),
                         fe.FrequencyErrorOptions())
    # the sweep: relative spacing 2e-5 (2e-3 of a 1 % resonance's half-width) from a third of the
    # lowest coupled frequency to the band edge (below it the transfers are smooth: 2000 log
    # points), the whole transfers by dense solves (the rigid parts cancel in the difference; the
    # truth's is removed by the rigid chain's own transfer)
    low = modal_t.omega[0] / 3
    w = np.concatenate([np.geomspace(band.grid[0], low, 2000)[:-1],
                        np.geomspace(low, band.omega_band, 100_000)])
    W = fe.input_weights(truth)
    rigid = lin_of(without_modes(chain, {k: range(2) for k in range(4)}))
    G_rigid = fe.rigid_gain(rigid)[None] / (1j * w)[:, None, None]     # K = 0: the 1/s alone
    Gt, Gm = dense_sweep(truth, ZETA, w), dense_sweep(model, ZETA, w)
    truth_hinf = np.max(fe.sigma_max((Gt - G_rigid) @ W))
    diff = (Gt - Gm) @ W
    hinf = np.max(fe.sigma_max(diff)) / truth_hinf
    h2 = fe.band_h2(diff, w) / fe.band_h2((Gt - G_rigid) @ W, w)
    assert err["hinf"] == pytest.approx(hinf, rel=1e-4) and err["h2"] == pytest.approx(h2, rel=1e-3)
    assert err["hinf"] > 0.1


# ------------------------------------------------------------ the band and a scene
def test_band_of_a_scene_at_rest_is_empty_and_the_thesis_drive_excites_the_lowest_modes():
    chain, y0 = chain_and_y0()
    lin = fe.linear_chain(chain, y0)
    modal = fe.ModalTransfer(lin, ZETA)
    t = np.linspace(0.0, 0.015, 1501)
    rest = fe.excitation_shares(lin, modal, np.zeros((t.size, 7)), t)
    assert np.isnan(fe.excited_band(modal.omega, rest, fe.FrequencyErrorOptions())[0])
    thesis = scenes.load_scene("thesis")
    share = fe.excitation_shares(lin, modal, fe.scene_inputs(thesis, t), t)
    top, n = fe.excited_band(modal.omega, share, fe.FrequencyErrorOptions())
    assert n >= 1 and top >= modal.omega[0]
    # a stricter threshold can only narrow the band
    top2, n2 = fe.excited_band(modal.omega, share, fe.FrequencyErrorOptions(excited_share=1e-3))
    assert n2 <= n and (np.isnan(top2) or top2 <= top)


def test_frequency_errors_of_a_scene_and_refusals():
    chain, y0 = chain_and_y0()
    thesis = scenes.load_scene("thesis")
    y0 = np.zeros(chain.n_coordinates)
    y0[:4] = thesis.initial_angles
    truth = fe.linear_chain(chain, y0)
    chains = {"truth": truth, "copy": truth,
              "missing": lin_of(without_modes(chain, {0: [0]}), thesis.initial_angles)}
    out = fe.frequency_errors(thesis, chains)
    assert out["damping_ratio"] == 0.01 and out["band"]["n_coupled"] == 12
    assert out["models"]["truth"]["hinf"] == 0.0 and out["models"]["copy"]["h2"] == 0.0
    assert out["models"]["missing"]["hinf"] > 0
    with pytest.raises(fe.FrequencyError, match="truth"):
        fe.frequency_errors(thesis, {"copy": truth})
    with pytest.raises(fe.FrequencyError):
        fe.FrequencyErrorOptions(damping_floor=0.0)


# ------------------------------------------------------------ E's sampling rule on a scene
def test_sampling_band_fails_a_grid_below_the_excited_modes_and_passes_a_fine_one():
    """The synthetic chain's excited modes on the thesis drive against two grids: one whose
    Nyquist frequency lies below f_max (must fail, with the one-line reason) and one at the
    longest interval the rule allows (must pass); a scene with initial rates is not judged."""
    chain = synthetic_modal_chain(3, seed=1)
    thesis = scenes.load_scene("thesis")
    y0 = np.zeros(chain.n_coordinates)
    y0[:4] = thesis.initial_angles
    lin = fe.linear_chain(chain, y0)
    found = fe.sampling_band(lin, thesis)
    f_max = found["f_max_hz"]
    assert f_max > 0 and found["mode"] >= 1
    # f_max is the highest mode at or above the share, from the shares themselves
    modal = fe.ModalTransfer(lin, ZETA)
    t = fe.scene_times(thesis)
    share = fe.excitation_shares(lin, modal, fe.scene_inputs(thesis, t), t)[:4].max(axis=0)
    counted = modal.omega[share >= error_measure.SAMPLING_SHARE]
    assert f_max == pytest.approx(counted.max() / (2 * np.pi), rel=1e-12)
    longest = error_measure.resolving_interval(f_max)
    coarse = replace(thesis, duration=0.01, output_interval=0.01 / np.floor(0.01 / longest / 2))
    fine = replace(thesis, duration=0.01, output_interval=0.01 / np.ceil(0.01 / longest))
    bad, good = fe.sampling_band(lin, coarse), fe.sampling_band(lin, fine)
    assert bad["resolved"] is False and "does not resolve" in bad["problem"] and "\n" not in bad["problem"]
    assert good["resolved"] is True and good["problem"] is None
    moving = replace(thesis, initial_rates=(0.3, 0.0, 0.0, 0.0))
    assert fe.sampling_band(lin, moving)["resolved"] is None

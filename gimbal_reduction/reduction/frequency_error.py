"""Frequency-domain error of a reduced model: the H-infinity and H2 norms of the difference between
its linearised chain's transfer and the truth's, over the band the scene excites.

The chain linearised at rest
-----------------------------
About the scene's initial configuration y0 (gimbal angles of the scene, every elastic coordinate
0, every rate 0) the equations of motion ``inverse_dynamics(y, y', y'', case) = tau`` are, to first
order in the deviation x = y - y0 and the inputs,

    M x'' + D x' + K x = B u,      M = M(y0),  K = diag(0_4, Omega^2),

with D the damping (below) and the inputs u = [a (3,); tau (4,)]: the case's angular acceleration
a [rad/s^2] in case axes and the four motor torques tau [in lbf] on the joint angles.
B = [-H, E_4]: H (n, 3) is the inverse dynamics' response to a unit case acceleration at rest (the
inertial load it puts on every coordinate), E_4 the torques' columns (1 on joint j).  Velocity-squared terms (centrifugal,
Coriolis) are second order at rest and dropped; every study scene starts at rest.

The outputs are rates, y = C x' (7,): the four gimbal rates and the stable platform's angular
velocity relative to the case (3,, platform axes at y0) [rad/s], the rate of the platform attitude
that the study tables compare (``multibody.platform_attitude``).  The transfer is

    G(s) = s C (s^2 M + s D + K)^-1 B      (7, 7).

Rigid and elastic parts
-----------------------
The joints carry no stiffness, so G has poles at s = 0.  Substituting g = g_r + J q,
J = -M_gg^-1 M_gq (``linearized.free_joints``), turns M into blockdiag(M_gg, S) with the Schur
complement S = M_qq - M_qg M_gg^-1 M_gq, while K and D (zero on the joints) become blockdiag(0, K_q),
blockdiag(0, D_q): the rigid and the elastic motion decouple exactly, and

    G(s) = (1/s) C_g M_gg^-1 B_g  +  s C T (s^2 S + s D_q + K_q)^-1 T^T B,     T = [J; I].

The first term (the rigid chain's 1/s: a torque or case acceleration integrates to a rate) holds
only the joint blocks M_gg, B_g, C_g, which at q = 0 are the rigid bodies' inertia: the same in
every model of the same bodies (``check_same_rigid`` verifies it).  So G_truth - G_model is the
difference of the elastic parts alone, finite at every frequency, and every norm below is of the
elastic part G_e (the rigid chain's G_e = 0: its relative error is exactly 1).

Inputs of different units are made commensurate by writing a torque as the joint acceleration
alpha it gives the rigid chain, tau = M_gg alpha: with G W, W = blockdiag(I_3, M_gg), every input is
an acceleration [rad/s^2], every output a rate [rad/s], G in s, and sigma_max is meaningful.

Damping of the evaluation, and the modal form
---------------------------------------------
An undamped chain has G = infinity at its coupled frequencies, and so would every H-infinity
norm.  Every chain, truth and model, is evaluated with modal damping of ratio
zeta = max(scene's, ``damping_floor``) (1 %, the damped study scene's) in its own undamped coupled
modes X (X^T S X = I, X^T K_q X = diag(omega^2): ``linearized.free_joint_basis``), D_q = S X
diag(2 zeta omega) X^T S (``coupled_damping``).  (The simulations damp the body modes instead;
in the coupled modes that damping is not diagonal, and diagonalising the (2m, 2m) first-order
matrix of the 400-mode truth took ~10x the symmetric eigenproblem, measured.)  The damping is a
device of the measure: a misplaced resonance costs an error of the order of (frequency shift) /
(half-power width), so the numbers hold at this damping.  Then

    G_e(i w) = sum_k (C T X)[:, k] (X^T T^T B)[k, :] i w / (omega_k^2 - w^2 + 2 i zeta omega_k w),

an (F, m) x (m, 49) product for F frequencies (``ModalTransfer``).  ``transfer_direct`` (a dense
complex solve of (K - w^2 M + i w D) per frequency) is the independent form: ``ModalTransfer``
checks itself against the Schur-complement solve at two frequencies, the tests against the whole
chain's.

The band
--------
What the scene's drive puts into coupled mode k of the truth: the undamped mode's rate
xi_k'(t) = Re[e^{i w_k t} int_0^t e^{-i w_k s} g_k(s) ds] (``frozen_chain.modal_rates``), the
drive's running Fourier transform at w_k, g_k = (X^T T^T B)_k u(t) its modal load.  Its share of
output n is e_nk = int (c_nk xi_k')^2 dt / int r_n^2 dt over the window, r_n the truth's linear
response (rigid and elastic).  The scene excites mode k if max_n e_nk >= ``excited_share``
(1e-10: below that its whole ringing, left out, would move the study's error measure E less than
the truth's own resolution, E ~ 1e-8 of static-100 against the truth).  The band is
[0, ``band_margin`` x the highest excited coupled frequency].

Norms on a grid
---------------
The grid (``frequency_grid``): a log grid of ``points_per_decade`` from 1e-3 of the lowest coupled
frequency to the band's edge, plus points at w_d + sigma x ``PEAK_OFFSETS`` around every damped pole
lambda = -sigma + i w_d of the truth reaching into the band (a resonance is 2 sigma wide), and
``MODEL_PEAK_OFFSETS`` around the model's.  H-infinity: max over the grid of
sigma_max((G_e,truth - G_e,model) W), polished by a golden-section search between the neighbours of
the largest sample; relative to the truth's (polished too).
H2 over the band: (1/pi int_0^w_band ||G(i w) W||_F^2 dw)^1/2 by the trapezoid rule; relative to
the truth's.

Units: in, lbf, s, rad; frequencies in rad/s unless named _hz.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gimbal_reduction.reduction.frozen_chain import modal_rates
from gimbal_reduction.solver.dynamics import compiled, error_measure, linearized, multibody

N_JOINTS = 4
INPUT_LABELS = ("case_ax", "case_ay", "case_az", "torque_1", "torque_2", "torque_3", "torque_4")
OUTPUT_LABELS = ("rate_1", "rate_2", "rate_3", "rate_4", "platform_wx", "platform_wy", "platform_wz")
N_INPUTS, N_OUTPUTS = len(INPUT_LABELS), len(OUTPUT_LABELS)

# Offsets of the refinement points around a damped pole, in units of its decay rate sigma (the
# half-power half-width), both sides: uniform steps of sigma/4 over the peak, sigma/2 on its
# flanks, where |1/(i w - lambda)| varies on the scale sigma.  With them the trapezoid rule gives
# an oscillator's H2 norm squared to 3e-4 at zeta = 0.01 and 1e-4 at 0.05 (2e-3 at 0.002, where
# the log grid's 2.3 % steps are 12 sigma: tests/reduction/test_frequency_error.py).  A model's
# own poles get the coarser MODEL_PEAK_OFFSETS (its resonances cost an evaluation of the truth
# at every point): its peak still within 1 % (sigma/8 steps) and polished by golden section.
PEAK_OFFSETS = np.concatenate([np.arange(0.0, 4.0, 0.25), np.arange(4.0, 16.01, 0.5)])
MODEL_PEAK_OFFSETS = np.array([0.0, 0.125, 0.25, 0.375, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0,
                               12.0, 16.0])
SELF_CHECK_RTOL = 1e-6       # modal against Schur-complement transfer (``ModalTransfer``)
RIGID_RTOL = 1e-9            # joint blocks of truth and model (``check_same_rigid``)


class FrequencyError(ValueError):
    """Bad input to the frequency-domain error (one-line message)."""


@dataclass(frozen=True)
class FrequencyErrorOptions:
    """How the frequency-domain error is evaluated (module docstring)."""
    damping_floor: float = 0.01         # [1] modal damping ratio at least this; source: the damped
    #                                     study scene's 1 % (config/scenes/damped.yaml)
    excited_share: float = 1e-10        # [1] share of a rate's mean square that makes a mode excited
    #                                     (chosen: below the truth's resolution in E, ~1e-8)
    band_margin: float = 1.1            # [1] band edge / highest excited coupled frequency (chosen:
    #                                     the top resonance, 2 zeta wide, lies inside)
    points_per_decade: int = 100        # [1/decade] of the log grid (chosen)
    decades_below: float = 3.0          # [decades] log grid from 10^-3 of the lowest coupled frequency
    golden_steps: int = 40              # golden-section steps polishing the H-infinity peak

    def __post_init__(self):
        if not (0 < self.damping_floor < 1 and self.excited_share > 0 and self.band_margin >= 1
                and self.points_per_decade >= 1 and self.decades_below > 0 and self.golden_steps >= 0):
            raise FrequencyError(f"FrequencyErrorOptions out of range: {self}")


@dataclass(frozen=True)
class LinearChain:
    """M x'' + D x' + K x = B u, y = C x' (module docstring; the damping D is the evaluation's,
    ``coupled_damping``).

    M (n, n) [lbf s^2/in in the mixed modal units of multibody]; stiffness (n,) [(rad/s)^2],
    diagonal, 0 on the 4 joints; B (n, 7): inputs case angular acceleration
    (3,) [rad/s^2], motor torques (4,) [in lbf]; C (7, n): outputs gimbal rates (4,) and platform
    angular velocity relative to the case (3,) [rad/s] per unit coordinate rate."""
    M: np.ndarray
    stiffness: np.ndarray
    B: np.ndarray
    C: np.ndarray

    @property
    def n_elastic(self):
        return self.M.shape[0] - N_JOINTS


# ------------------------------------------------------------ the linear chain
def attitude_rate_matrix(chain, y0):
    """A (3, n): the platform's angular velocity relative to the case, in platform axes at y0
    [rad/s], per unit rate of each coordinate, to first order at y0 with the elastic coordinates 0.

    ``multibody.platform_attitude`` is the product R = R_1 F_2 F_3 F_4, R_1 = C_1 Rx(gamma_1),
    F_j = E_j C Rx(gamma_j), E_j = Rx(th_1) Ry(th_2) Rz(th_3) (= I + skew(d th) to first order),
    th = Theta q of body j's parent.  A factor's increment I + skew(v) between P and Q (R = P Q)
    is the platform-axes rotation Q^T v: so gamma_j contributes After_j^T e_x, After_j the factors
    right of Rx(gamma_j), and the parent's elastic rotation d th contributes (C Rx(gamma_j)
    After_j)^T Theta."""
    y0 = np.asarray(y0, float)
    n = chain.n_coordinates
    C = chain.parent_to_child
    rx = [multibody.rot_x(g) for g in y0[:N_JOINTS]]
    after = [np.eye(3)] * N_JOINTS              # after[j]: product of the factors right of Rx(gamma_j+1)
    for j in range(N_JOINTS - 2, -1, -1):
        after[j] = C @ rx[j + 1] @ after[j + 1]     # at q = 0 every E is I
    A = np.zeros((3, n))
    for j in range(N_JOINTS):
        A[:, j] = after[j].T @ multibody.E_X
    for j in range(1, N_JOINTS):                # joint j+1 sits on body j+1's parent, chain.bodies[j - 1]
        parent = chain.bodies[j - 1]
        if parent.n_modes:
            A[:, chain.slices[j - 1]] = (C @ rx[j] @ after[j]).T @ np.asarray(parent.inside_rotation, float)
    return A


def linear_chain(chain, y0):
    """The chain linearised at rest at configuration y0 (elastic coordinates must be 0): a
    ``LinearChain``."""
    y0 = np.asarray(y0, float)
    n = chain.n_coordinates
    if y0.shape != (n,) or np.any(y0[N_JOINTS:] != 0):
        raise FrequencyError(f"linear_chain: y0 must be ({n},) with the elastic coordinates 0, "
                             f"got shape {y0.shape}")
    fast = compiled.FastChain(chain)
    M = fast.mass_matrix(y0)
    zero, w0 = np.zeros(n), np.zeros(6)
    B = np.zeros((n, N_INPUTS))
    base = fast.inverse_dynamics(y0, zero, zero, w0, w0)        # K y0 = 0 at rest
    for k in range(3):
        dw = np.zeros(6)
        dw[3 + k] = 1.0
        B[:, k] = -(fast.inverse_dynamics(y0, zero, zero, w0, dw) - base)
    B[:N_JOINTS, 3:] = np.eye(N_JOINTS)
    C = np.zeros((N_OUTPUTS, n))
    C[:N_JOINTS, :N_JOINTS] = np.eye(N_JOINTS)
    C[N_JOINTS:] = attitude_rate_matrix(chain, y0)
    return LinearChain(M=M, stiffness=chain.stiffness_diagonal(), B=B, C=C)


def input_weights(lin):
    """W (7, 7) = blockdiag(I_3, M_gg): G W has every input a joint or case acceleration [rad/s^2]."""
    W = np.eye(N_INPUTS)
    W[3:, 3:] = lin.M[:N_JOINTS, :N_JOINTS]
    return W


def rigid_gain(lin):
    """C_g M_gg^-1 B_g (7, 7): the rigid part of G is this over s."""
    g = slice(0, N_JOINTS)
    return lin.C[:, g] @ np.linalg.solve(lin.M[g, g], lin.B[g])


def check_same_rigid(truth, model, label="model"):
    """Raise FrequencyError unless the model's joint blocks (M_gg, B_g, C_g: the rigid chain) are
    the truth's to RIGID_RTOL: then the rigid parts of their transfers cancel exactly."""
    g = slice(0, N_JOINTS)
    for name, a, b in (("M_gg", truth.M[g, g], model.M[g, g]), ("B_g", truth.B[g], model.B[g]),
                       ("C_g", truth.C[:, g], model.C[:, g])):
        if np.max(np.abs(a - b)) > RIGID_RTOL * max(np.max(np.abs(a)), 1e-300):
            raise FrequencyError(f"{label}: its rigid chain ({name}) differs from the truth's "
                                 f"(other bodies or configuration?)")


# ------------------------------------------------------------ transfers
def transfer_direct(M, D, K, B, C, omega, velocity=True):
    """G(i w) (F, p, q) = C (i w)^v (K - w^2 M + i w D)^-1 B at every omega (F,) [rad/s], v = 1 for
    velocity outputs (else displacement): one dense complex solve per frequency.  M, D, K (n, n),
    B (n, q), C (p, n).  The reference of ``ModalTransfer`` (and the whole transfer, rigid part
    included: singular at w = 0 when K is)."""
    M, D, K = (np.asarray(a, float) for a in (M, D, K))
    out = []
    for w in np.asarray(omega, float):
        x = np.linalg.solve(K - w * w * M + 1j * w * D, B)
        out.append((1j * w if velocity else 1.0) * (C @ x))
    return np.array(out)


def coupled_damping(lin, zeta):
    """D (n, n): modal damping of ratio zeta [1] in the chain's undamped coupled modes, in the
    coordinates x: blockdiag(0_4, D_q), D_q = S X diag(2 zeta omega) X^T S (X^T D_q X = diag(2 zeta
    omega) because X^T S X = I), the joint rows zero (the damping of ``ModalTransfer``)."""
    n = lin.M.shape[0]
    D = np.zeros((n, n))
    if n > N_JOINTS:
        omega, _, X, Y = linearized.free_joint_basis(lin.M, lin.stiffness[N_JOINTS:])
        D[N_JOINTS:, N_JOINTS:] = (Y * (2.0 * zeta * omega)) @ Y.T          # Y = S X
    return D


class ModalTransfer:
    """The elastic transfer G_e(i w) (7, 7) of a ``LinearChain`` with modal damping of ratio zeta in
    its coupled modes (module docstring, Modal form), from one symmetric eigenproblem; any
    frequencies after that cost an (F, m) x (m, 49) product.

    omega (m,) the undamped coupled frequencies [rad/s] ascending; modal_inputs (m, 7) =
    X^T T^T B, modal_outputs (7, m) = C T X."""

    def __init__(self, lin, zeta, check=True):
        if not 0 < zeta < 1:
            raise FrequencyError(f"ModalTransfer: damping ratio must lie in (0, 1), got {zeta}")
        m = lin.n_elastic
        self.m, self.zeta = m, float(zeta)
        if m == 0:
            self.omega = np.zeros(0)
            self.modal_inputs = np.zeros((0, N_INPUTS))
            self.modal_outputs = np.zeros((N_OUTPUTS, 0))
            self._residues = np.zeros((0, N_OUTPUTS * N_INPUTS))
            return
        kq = lin.stiffness[N_JOINTS:]
        if np.any(kq <= 0):
            raise FrequencyError("ModalTransfer: every elastic coordinate needs a positive stiffness")
        omega, joint_of_mode, X, Y = linearized.free_joint_basis(lin.M, kq)
        T = np.vstack([joint_of_mode, np.eye(m)])               # (n, m): [J; I]
        self.omega = omega
        self._Y = Y                                              # S X: the damping's factor
        self.modal_inputs = X.T @ (T.T @ lin.B)                  # (m, 7)
        self.modal_outputs = (lin.C @ T) @ X                     # (7, m)
        self._residues = np.einsum("pk,kq->kpq", self.modal_outputs,
                                   self.modal_inputs).reshape(m, -1).astype(complex)
        if check:
            self._self_check(lin)

    def __call__(self, omega):
        """G_e(i w) (F, 7, 7) at omega (F,) [rad/s]: sum_k c_k b_k^T i w / (w_k^2 - w^2 + 2 i zeta
        w_k w)."""
        w = np.asarray(omega, float)
        if self.m == 0:
            return np.zeros((w.size, N_OUTPUTS, N_INPUTS), complex)
        wk = self.omega[None, :]
        s = 1j * w[:, None]
        weights = s / (wk * wk + s * s + 2.0 * self.zeta * wk * s)
        return (weights @ self._residues).reshape(w.size, N_OUTPUTS, N_INPUTS)

    def _self_check(self, lin):
        """Compare with the Schur-complement solve s C T (s^2 S + s D_q + K_q)^-1 T^T B at two
        frequencies in the band of the modes (FrequencyError beyond SELF_CHECK_RTOL)."""
        joint_of_mode, S = linearized.free_joints(lin.M)
        T = np.vstack([joint_of_mode, np.eye(self.m)])
        D = (self._Y * (2.0 * self.zeta * self.omega)) @ self._Y.T       # S X diag(2 zeta w) X^T S
        w = np.array([0.5 * self.omega[0], np.sqrt(self.omega[0] * self.omega[-1])])
        ref = transfer_direct(S, D, np.diag(lin.stiffness[N_JOINTS:]), T.T @ lin.B, lin.C @ T, w)
        got = self(w)
        scale = max(float(np.max(np.abs(ref))), 1e-300)
        if np.max(np.abs(got - ref)) > SELF_CHECK_RTOL * scale:
            raise FrequencyError(f"ModalTransfer: the modal form misses the direct solve by "
                                 f"{np.max(np.abs(got - ref)) / scale:.2e}")

    def resonances(self, omega_max):
        """(w_d, sigma) of the poles lambda = -zeta w_k + i w_k sqrt(1 - zeta^2) whose refinement
        points reach below omega_max (w_d - sigma max(PEAK_OFFSETS) < omega_max): damped frequency
        [rad/s] and decay rate [1/s]."""
        wd = self.omega * np.sqrt(1.0 - self.zeta ** 2)
        keep = wd - PEAK_OFFSETS[-1] * self.zeta * self.omega < omega_max
        return wd[keep], self.zeta * self.omega[keep]


# ------------------------------------------------------------ the band
def excitation_shares(truth, modal, scene_inputs, t):
    """share (7, m): the share e_nk of output n's mean square over the window that the truth's
    undamped coupled mode k (frequency modal.omega[k]) makes under the scene's drive (module
    docstring, The band).  truth: ``LinearChain``; modal: its ``ModalTransfer`` (the damping is not
    used: the drive's reach is judged undamped); scene_inputs (T, 7): u(t) at the times t (T,) [s]."""
    t = np.asarray(t, float)
    u = np.asarray(scene_inputs, float)
    if u.shape != (t.size, N_INPUTS):
        raise FrequencyError(f"excitation_shares: inputs must be (T, 7) = ({t.size}, 7), got {u.shape}")
    # rigid response: C_g M_gg^-1 B_g int_0^t u (cumulative trapezoid)
    u_int = np.concatenate([np.zeros((1, N_INPUTS)),
                            np.cumsum(0.5 * np.diff(t)[:, None] * (u[1:] + u[:-1]), axis=0)])
    rigid = u_int @ rigid_gain(truth).T                                     # (T, 7)
    if modal.m == 0:
        return np.zeros((N_OUTPUTS, 0))
    rates = modal_rates(modal.omega, u @ modal.modal_inputs.T, t)           # (T, m)
    reference = rigid + rates @ modal.modal_outputs.T                       # (T, 7)
    # the mean squares by the trapezoid rule, int f^2 dt = sum_k w_k f_k^2 with its weights w (T,):
    # one pass over the (T, m) rates, no (T, m) temporaries (1.3 s a call on long's truth with them)
    dt = np.diff(t)
    w = np.zeros(t.size)
    w[:-1] += 0.5 * dt
    w[1:] += 0.5 * dt
    den = np.einsum("k,kn,kn->n", w, reference, reference)                 # (7,)
    num = modal.modal_outputs ** 2 * np.einsum("k,km,km->m", w, rates, rates)[None, :]
    return np.where(den[:, None] > 0, num / np.where(den > 0, den, 1.0)[:, None], 0.0)


def scene_inputs(scene, t):
    """u (T, 7) of a scene at times t (T,) [s]: case angular acceleration [rad/s^2], motor torques
    [in lbf] (constant over the scene)."""
    t = np.asarray(t, float)
    a = np.array([scene.case.angular_acceleration(tk) for tk in t]).reshape(t.size, 3)
    return np.hstack([a, np.broadcast_to(np.asarray(scene.motor_torques, float), (t.size, 4))])


def excited_band(omega, share, options):
    """(highest excited coupled frequency [rad/s] or NaN if none, number of excited modes)."""
    excited = np.max(share, axis=0) >= options.excited_share if share.size else np.zeros(0, bool)
    if not np.any(excited):
        return float("nan"), 0
    return float(np.max(omega[excited])), int(np.sum(excited))


def sampling_band(truth, scene, share=error_measure.SAMPLING_SHARE,
                  margin=error_measure.SAMPLING_MARGIN, zeta=0.01):
    """What E's sampling rule (``error_measure``, module docstring there) asks of a scene's output
    grid: the highest coupled frequency of the truth whose share of a gimbal rate's mean square
    under the scene's drive is at least ``share`` (``excitation_shares``, outputs rate_1..rate_4;
    judged undamped, so a damped scene's ringing counts in full), and whether the scene's output
    interval resolves it.  truth: the truth's ``LinearChain`` at the scene's initial state; scene:
    ``scenes.Scene``; zeta only builds the modal form (the shares do not use it).  Returns a
    JSON-ready dict: f_max_hz (None if no mode reaches the share), mode (1-based rank of that
    coupled mode), share, margin, output_interval_s, nyquist_hz, longest_interval_s, resolved,
    problem (the one-line reason or None), note.  A scene that does not start at rest (initial gimbal
    rates or case angular velocity) drives the modes through velocity terms the linearisation at
    rest drops: its shares say nothing, and resolved is None (not judged), with the reason."""
    moving = any(scene.initial_rates) or any(scene.case.omega0)
    if moving:
        return {"f_max_hz": None, "mode": None, "share": share, "margin": margin,
                "output_interval_s": scene.output_interval, "nyquist_hz": 0.5 / scene.output_interval,
                "longest_interval_s": None, "resolved": None, "problem": None,
                "note": f"scene {scene.name} does not start at rest: its excitation is not judged "
                        "by the linear chain at rest (the sampling rule is not evaluated)"}
    modal = ModalTransfer(truth, zeta)
    t = scene_times(scene)
    shares = excitation_shares(truth, modal, scene_inputs(scene, t), t)[:N_JOINTS]     # (4, m)
    counted = np.max(shares, axis=0) >= share if shares.size else np.zeros(0, bool)
    top = int(np.argmax(np.where(counted, modal.omega, -1.0))) if np.any(counted) else None
    f_max = float(modal.omega[top] / (2 * np.pi)) if top is not None else float("nan")
    problem = error_measure.sampling_problem(scene.output_interval, f_max, f"scene {scene.name}", margin)
    rank = None if top is None else int(np.sum(modal.omega < modal.omega[top])) + 1
    return {"f_max_hz": f_max if top is not None else None, "mode": rank, "share": share,
            "margin": margin, "output_interval_s": scene.output_interval,
            "nyquist_hz": 0.5 / scene.output_interval,
            "longest_interval_s": error_measure.resolving_interval(f_max, margin) if top is not None else None,
            "resolved": problem is None, "problem": problem, "note": None}


# ------------------------------------------------------------ norms on a grid
def frequency_grid(omega_low, omega_band, resonances, options, offsets=PEAK_OFFSETS):
    """Sorted frequencies (F,) [rad/s]: a log grid from omega_low to omega_band and the refinement
    points w_d + sigma ``offsets`` (both sides) of every (w_d, sigma) in ``resonances`` (list of
    array pairs), clipped to (0, omega_band]; omega_band itself is the last."""
    decades = np.log10(omega_band / omega_low)
    base = np.logspace(np.log10(omega_low), np.log10(omega_band),
                       max(2, int(np.ceil(decades * options.points_per_decade)) + 1))
    pts = [base]
    offs = np.concatenate([-offsets[:0:-1], offsets])
    for wd, sigma in resonances:
        pts.append((wd[:, None] + sigma[:, None] * offs[None, :]).ravel())
    w = np.concatenate(pts)
    w = w[(w > 0) & (w < omega_band)]
    return np.unique(np.append(w, omega_band))        # the edge itself (logspace may round past it)


def band_h2(G, omega):
    """(1/pi int ||G(i w)||_F^2 dw)^1/2 over the grid omega (F,) by the trapezoid rule; G (F, p, q)."""
    return float(np.sqrt(np.trapezoid(np.sum(np.abs(G) ** 2, axis=(1, 2)), omega) / np.pi))


def sigma_max(G):
    """Largest singular value (F,) of each G[f] (F, p, q): the square root of the largest eigenvalue
    of G^H G (Hermitian, q x q; half the time of a batched SVD, the same to rounding)."""
    if not len(G):
        return np.zeros(0)
    H = np.conj(np.swapaxes(G, 1, 2)) @ G
    return np.sqrt(np.maximum(np.linalg.eigvalsh(H)[:, -1], 0.0))


def peak_sigma(G):
    """(largest sigma_max over the samples of G (F, p, q), its index).  Only the samples whose
    Frobenius norm reaches the largest over sqrt(min(p, q)) can hold it (sigma_max <= ||G||_F <=
    sqrt(rank) sigma_max), so sigma_max is computed for those alone."""
    fro = np.sqrt(np.sum(np.abs(G) ** 2, axis=(1, 2)))
    cand = np.flatnonzero(fro >= fro.max() / np.sqrt(min(G.shape[1:])))
    smax = sigma_max(G[cand])
    i = int(np.argmax(smax))
    return float(smax[i]), int(cand[i])


def _polish_peak(fun, omega, G, steps):
    """(max, argmax) of fun over [omega[i-1], omega[i+1]] around the grid's largest sigma_max of G
    (F, p, q), by a golden-section search (``steps`` steps) started from the grid."""
    best, i = peak_sigma(G)
    arg = float(omega[i])
    lo, hi = omega[max(i - 1, 0)], omega[min(i + 1, omega.size - 1)]
    r = (np.sqrt(5.0) - 1.0) / 2.0
    a, b = hi - r * (hi - lo), lo + r * (hi - lo)
    fa, fb = fun(a), fun(b)
    for _ in range(steps):
        if fa > fb:
            hi, b, fb = b, a, fa
            a = hi - r * (hi - lo)
            fa = fun(a)
        else:
            lo, a, fa = a, b, fb
            b = lo + r * (hi - lo)
            fb = fun(b)
    for f, w in ((fa, a), (fb, b)):
        if f > best:
            best, arg = f, w
    return best, arg


@dataclass(frozen=True)
class Band:
    """The band of a scene: its edge and top excited frequency [rad/s], the truth's transfer on the
    common grid (the log grid and the truth's resonances), and its norms over the band."""
    omega_top: float
    omega_band: float
    n_excited: int
    grid: np.ndarray
    truth_G: np.ndarray
    truth_hinf: float
    truth_h2: float


def make_band(truth_modal, truth_weights, omega_top, n_excited, options):
    """The ``Band`` of a truth (``ModalTransfer``, input weights (7, 7)) up to options.band_margin x
    omega_top [rad/s]."""
    omega_band = options.band_margin * omega_top
    low = truth_modal.omega[0] * 10.0 ** -options.decades_below
    grid = frequency_grid(low, omega_band, [truth_modal.resonances(omega_band)], options)
    G = truth_modal(grid) @ truth_weights

    def norm_at(w):
        return float(sigma_max(truth_modal(np.array([w])) @ truth_weights)[0])
    hinf, _ = _polish_peak(norm_at, grid, G, options.golden_steps)
    return Band(omega_top=omega_top, omega_band=omega_band, n_excited=n_excited, grid=grid,
                truth_G=G, truth_hinf=hinf, truth_h2=band_h2(G, grid))


def model_error(band, truth_modal, model_modal, weights, options):
    """dict: ``hinf`` and ``h2`` relative errors of a model (``ModalTransfer``) against the truth
    over the band, ``hinf_hz`` where the H-infinity error peaks [Hz] (None for no error), ``grid``
    the number of frequencies.

    The grid is the band's plus the refinement points of the model's own resonances in the band
    (the error also peaks where the model rings and the truth does not)."""
    wd, sigma = model_modal.resonances(band.omega_band)
    extra = frequency_grid(band.grid[0], band.omega_band, [(wd, sigma)], options, MODEL_PEAK_OFFSETS)
    extra = np.setdiff1d(extra, band.grid, assume_unique=True)
    grid = np.concatenate([band.grid, extra])
    G_truth = np.concatenate([band.truth_G, truth_modal(extra) @ weights])
    diff = G_truth - model_modal(grid) @ weights
    order = np.argsort(grid)
    grid, diff = grid[order], diff[order]

    def err_at(w):
        w = np.array([w])
        return float(sigma_max((truth_modal(w) - model_modal(w)) @ weights)[0])
    hinf, arg = _polish_peak(err_at, grid, diff, options.golden_steps)
    rel = (lambda x, ref: x / ref if ref > 0 else float("nan"))
    return {"hinf": rel(hinf, band.truth_hinf), "h2": rel(band_h2(diff, grid), band.truth_h2),
            "hinf_hz": arg / (2 * np.pi) if hinf > 0 else None, "grid": int(grid.size)}


# ------------------------------------------------------------ a scene's models
def scene_times(scene):
    """The scene's output samples t (T,) [s] (its duration in steps of its output interval)."""
    n = int(round(scene.duration / scene.output_interval))
    return np.linspace(0.0, scene.duration, n + 1)


def frequency_errors(scene, chains, truth="truth", options=FrequencyErrorOptions()):
    """The frequency-domain error of every model of a scene against its truth, as a JSON-ready dict.

    scene: ``scenes.Scene``; chains: {model name: ``LinearChain``} holding ``truth`` (linearised at
    the scene's initial configuration, ``linear_chain``).  Returns {scene, units, damping_ratio,
    band: {top_hz, edge_hz, n_excited, n_coupled, excited_share}, truth_norms: {hinf [s], h2
    [s^1/2]}, models: {name: {hinf, h2 (relative, 1), hinf_hz}}}; the band and every error None
    (JSON null) if the scene excites no coupled mode."""
    if truth not in chains:
        raise FrequencyError(f"frequency_errors: the truth ({truth!r}) is not among the models")
    zeta = max(float(scene.damping_ratio), options.damping_floor)
    lin_t = chains[truth]
    weights = input_weights(lin_t)
    modal_t = ModalTransfer(lin_t, zeta)
    t = scene_times(scene)
    share = excitation_shares(lin_t, modal_t, scene_inputs(scene, t), t)
    top, n_excited = excited_band(modal_t.omega, share, options)
    excited = bool(np.isfinite(top))
    out = {"scene": scene.name, "damping_ratio": zeta,
           "units": {"hinf": "1 (relative to the truth's)", "h2": "1 (relative to the truth's)",
                     "frequencies": "Hz", "truth_norms": "s (inputs as accelerations, outputs rates)"},
           "band": {"top_hz": top / (2 * np.pi) if excited else None,
                    "edge_hz": options.band_margin * top / (2 * np.pi) if excited else None,
                    "n_excited": n_excited, "n_coupled": int(modal_t.m),
                    "excited_share": options.excited_share},
           "models": {}}
    if not excited:
        out["truth_norms"] = {"hinf": None, "h2": None}
        out["models"] = {name: {"hinf": None, "h2": None, "hinf_hz": None} for name in chains}
        return out
    band = make_band(modal_t, weights, top, n_excited, options)
    out["truth_norms"] = {"hinf": band.truth_hinf, "h2": band.truth_h2}
    for name, lin in chains.items():
        check_same_rigid(lin_t, lin, name)
        modal = modal_t if name == truth else ModalTransfer(lin, zeta)
        err = model_error(band, modal_t, modal, weights, options)
        out["models"][name] = {k: err[k] for k in ("hinf", "h2", "hinf_hz")}
    return out

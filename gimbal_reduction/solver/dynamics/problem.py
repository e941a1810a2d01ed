"""What an integrator integrates: a chain with its case motion, motor torques and initial
state (``Problem``), and the choice between the compiled and the NumPy right-hand side
(``make_rhs``).

``gimbal_reduction.solver.dynamics.integrators`` works on this interface only: ``rhs``, ``residual``,
``solve``, ``mass_matrix``, ``kinetic_energy``, ``potential_energy``, ``energy``,
``input_power``, ``stiffness_diagonal``, ``damping_diagonal``, ``y0``, ``yd0``, ``omega_max``
(computed on first use), the two
optional compiled paths ``rk4_steps`` and ``rk4_run`` (None when there is none), and the
optional ``mass_factors`` (returns None when there are none; an integrator without it uses
``mass_matrix``).
"""

import numpy as np

from gimbal_reduction.solver.dynamics import linearized
from gimbal_reduction.solver.dynamics.multibody import (CaseMotion, accelerations, case_power, inverse_dynamics,
                                       kinetic_energy, mass_matrix, solve_mass, torque_function)

# Numba is required (workflow/envs/requirements.txt): without it this import fails, never a
# silent fallback to the NumPy reference path (~100x slower); make_rhs(fast=False) is that path
from gimbal_reduction.solver.dynamics import compiled


def make_rhs(chain, case=None, torque=None, fast=True):
    """y'' = rhs(t, y, y'): the chain's accelerations, compiled (``compiled.CompiledRhs``)
    when fast, else (on request only) the NumPy reference ``multibody.accelerations``."""
    if fast:
        return compiled.make_rhs(chain, case, torque)
    tau = torque_function(torque)

    def rhs(t, y, yd):
        return accelerations(chain, y, yd, t, case, tau(t))
    return rhs


class Problem:
    """A chain with its case motion, motor torques and initial state: what an
    integrator needs (``gimbal_reduction.solver.dynamics.integrators.integrate``).

    torque: (4,) constant motor torques [in lbf] or a callable t -> (4,).
    omega_max: the stability bound's frequency [rad/s]; default
    ``linearized.coupled_omega_max(chain, y0)`` (the coupled chain's highest frequency),
    computed when first asked for.
    ``modal_omega_max`` is the largest kept modal frequency, for reference.

    Optional compiled paths (None unless the right-hand side is compiled and the torques
    are constant): ``rk4_steps(y, y', t0, h, n) -> (y, y')``, n RK4 steps in one
    compiled call; ``rk4_run(y0, y'0, t_out, h, n_sub, growth) -> (Y, Yd, energy, info)``,
    a whole RK4 run with the energy watch (``kernels.rk4.rk4_integrate``)."""

    def __init__(self, chain, case=None, torque=None, y0=None, yd0=None, fast=True, omega_max=None):
        self.chain = chain
        self.case = case or CaseMotion()
        self.torque = torque_function(torque)        # t -> (4,) [in lbf]
        n = chain.n_coordinates
        self.y0 = np.zeros(n) if y0 is None else np.asarray(y0, float)
        self.yd0 = np.zeros(n) if yd0 is None else np.asarray(yd0, float)
        rhs = make_rhs(chain, self.case, torque, fast=fast)
        compiled_rhs = rhs if isinstance(rhs, compiled.CompiledRhs) else None
        self.rhs = rhs if compiled_rhs is None else compiled_rhs.rhs     # (the plain function: cheaper per call)
        self.modal_omega_max = chain.omega_max            # largest kept modal frequency
        self._omega_max = None if omega_max is None else float(omega_max)
        self.stiffness_diagonal = chain.stiffness_diagonal()
        self.damping_diagonal = chain.damping_diagonal()
        self._fast = None if compiled_rhs is None else compiled_rhs.fast_chain      # compiled kernels
        self._twist = self.case.twist if compiled_rhs is None else compiled_rhs.case_twist
        has_rk4 = compiled_rhs is not None and compiled_rhs.has_rk4
        self.rk4_steps = compiled_rhs.rk4_steps if has_rk4 else None
        self.rk4_run = compiled_rhs.rk4_integrate if has_rk4 else None

    @property
    def omega_max(self):
        """The explicit integrators' stability bound [rad/s]: the coupled chain's highest
        frequency (``linearized.coupled_omega_max``, ~7 eigenvalue problems), computed on
        first use only (the exponential integrator never needs it)."""
        if self._omega_max is None:
            self._omega_max = linearized.coupled_omega_max(self.chain, self.y0)
        return self._omega_max

    @property
    def damped_spectrum(self):
        """Eigenvalues [1/s] (complex) of the chain linearised with its modal damping at the
        configurations ``omega_max`` samples (``linearized.coupled_damped_spectrum``), computed
        on first use: the RK4 bound of a damped chain (``integrators.rk4_limit``)."""
        if getattr(self, "_damped_spectrum", None) is None:
            self._damped_spectrum = linearized.coupled_damped_spectrum(self.chain, self.y0)
        return self._damped_spectrum

    @omega_max.setter
    def omega_max(self, value):
        self._omega_max = float(value)

    def mass_matrix(self, y):
        """M(y) (n, n) [lbf s^2 in and mixed units of the coordinates] (compiled when
        available): the exponential integrator's linearisation."""
        if self._fast is not None:
            return self._fast.mass_matrix(y)
        return mass_matrix(self.chain, y)

    def mass_factors(self, y):
        """M(y) in the composite assembly's factored form (``compiled.MassFactors``), or None
        without the compiled kernels: the exponential integrator's frequency updates read
        only quadratic forms of M, which the factors give at a fraction of the cost."""
        if self._fast is not None:
            return self._fast.mass_factors(y)
        return None

    def tau(self, t):
        out = np.zeros(self.chain.n_coordinates)
        out[:4] = self.torque(t)
        return out

    def residual(self, t, y, yd, ydd):
        """M(y) y'' + c(y, y', t) - tau(t)."""
        if self._fast is not None:
            w1, dw1 = self.case.twist(t)
            return self._fast.inverse_dynamics(y, yd, ydd, w1, dw1) - self.tau(t)
        return inverse_dynamics(self.chain, y, yd, ydd, t, self.case) - self.tau(t)

    def solve(self, y, r, modal_diagonal=None):
        """(M(y) + diag(0, d - 1))^-1 r by the articulated-body recursion."""
        if self._fast is not None:
            return self._fast.solve_mass(y, r, modal_diagonal)
        return solve_mass(self.chain, y, r, modal_diagonal)

    def kinetic_energy(self, t, y, yd):
        """T [in lbf] (compiled path when available)."""
        if self._fast is not None:
            w1, _ = self._twist(t)
            return float(self._fast.kinetic_energy(y, yd, w1))
        return kinetic_energy(self.chain, y, yd, t, self.case)

    def potential_energy(self, y):
        """U = 1/2 sum Omega^2 q^2 [in lbf] (precomputed stiffness diagonal)."""
        y = np.asarray(y, float)
        return float(0.5 * np.dot(self.stiffness_diagonal * y, y))

    def energy(self, t, y, yd):
        """T + U [in lbf]."""
        return self.kinetic_energy(t, y, yd) + self.potential_energy(y)

    def energy_history(self, t, Y, Yd):
        """(kinetic, potential, input_power) (T,) each at the samples t (T,), Y, Yd (T, n): the
        values of ``kinetic_energy``, ``potential_energy`` and ``input_power`` at every sample,
        with the per-sample Python work hoisted out of the loop on the compiled path (one case
        twist per sample, the compiled kernels called directly, torques, damping and stiffness
        terms as array products): ~30 % less per sample, the same values to rounding."""
        t = np.asarray(t, float)
        Y, Yd = np.ascontiguousarray(Y, dtype=float), np.ascontiguousarray(Yd, dtype=float)
        tau = np.array([self.torque(tk) for tk in t], float).reshape(t.size, 4)
        U = 0.5 * np.einsum("j,ij,ij->i", self.stiffness_diagonal, Y, Y)
        P = np.einsum("ij,ij->i", tau, Yd[:, :4]) - np.einsum("j,ij,ij->i", self.damping_diagonal, Yd, Yd)
        if self._fast is None:
            T = np.array([self.kinetic_energy(tk, y, yd) for tk, y, yd in zip(t, Y, Yd)])
            if not self.case.at_rest:
                P += np.array([case_power(self.chain, y, yd, self.rhs(tk, y, yd), tk, self.case)
                               for tk, y, yd in zip(t, Y, Yd)])
            return T, U, P
        T, P_case = self._fast.energy_samples(t, Y, Yd, tau, self._twist, self.case.at_rest)
        return T, U, P + P_case

    def input_power(self, t, y, yd):
        """Power fed in by the case motion and the motors, minus modal damping [in lbf/s]."""
        tau = self.torque(t)
        P = float(np.dot(tau, yd[:4])) - float(np.sum(self.damping_diagonal * yd * yd))
        if not self.case.at_rest:
            if self._fast is not None:          # accelerations and wrench in one compiled call
                w1, dw1 = self._twist(t)
                P += self._fast.case_power_at(y, yd, w1, dw1, tau)
            else:
                P += case_power(self.chain, y, yd, self.rhs(t, y, yd), t, self.case)
        return P

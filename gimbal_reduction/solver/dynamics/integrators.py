"""Time integrators for M(y) y'' = f(y, y', t).

Four methods, one interface (``integrate``):

* ``exponential``: the modal exponential integrator (``gimbal_reduction.solver.dynamics.exponential``,
  docs/exponential.md), the default.  The linearised chain's modes are solved in closed
  form and only the slow remainder is stepped (exponential Adams, error control
  from ``tol``, re-linearisation as the gimbals turn), so its step is not bounded by
  omega_max: ~30 steps for the thesis window where RK4 needs 1e5.
* ``rk4``: the classical fixed-step fourth-order Runge-Kutta method, as the
  thesis used.  Explicit, so its step is bounded by the highest frequency
  of the chain: on the imaginary axis (undamped modes) RK4 is stable for
  h Omega <= 2 sqrt 2 = 2.83 and on the real axis for h|lambda| <= 2.785; the
  project uses the smaller, 2.785 / omega_max, as the limit (it also covers
  lightly damped modes).  omega_max is ``problem.omega_max``: the highest
  frequency of the coupled chain linearised at the initial state
  (``linearized.coupled_omega_max``).  It is NOT the largest kept modal
  frequency: the free joint angles remove inertia from the modal blocks
  (the modes carry momentum about the drive axes), which raises the coupled
  frequencies above the kept ones -- by 1.5-3x on the real bodies, which made
  RK4 at half the old "limit" diverge (docs/dynamics.md Section 6).
  Default step: ``RK4_DEFAULT_FRACTION``
  of the limit; a step beyond the limit is refused.
* ``dop853``: scipy's embedded Dormand-Prince 8(5,3) with error control.  A
  home-made Dormand-Prince 5(4) would add code without adding anything:
  DOP853 is the same family, higher order (fewer steps at tight tolerance,
  which is what a reference solution needs), with dense output, and it is
  maintained and tested upstream.  One run over the window, the output times
  read from its dense output.  For a stiff (high-frequency) model it is
  still bounded by stability, like any explicit method; it is the accuracy
  reference on low-frequency models.
* ``generalized-alpha``: the implicit generalised-alpha method (Chung &
  Hulbert 1993, in the Arnold & Bruls 2007 form for multibody systems),
  second order, unconditionally stable for the linear elastic part, with
  numerical damping set by rho_inf (1: none, trapezoidal-like; 0: strongest).
  Its step is NOT bounded by omega_max: modes far above 1/h are filtered.
  Each step solves R(a) = M(y) a + c(y, y', t) - tau = 0 by Newton's method
  with the iteration matrix M(y) + gamma' C + beta' K (the exact Jacobian
  without the slow derivatives of the inertia and velocity terms), applied by
  the same articulated-body recursion as the right-hand side with the modal
  mass diagonal replaced by 1 + gamma' c_i + beta' Omega_i^2.

Divergence (a non-finite state, or the energy growing beyond
``growth_factor`` times the larger of the initial energy and the work fed in)
stops a run with DivergenceError naming the time, the model and the step.

The integrators see a problem only through its interface (``gimbal_reduction.solver.dynamics.problem``:
rhs, residual, solve, energies, input_power, diagonals, y0, yd0, omega_max, and the
optional compiled RK4 paths ``rk4_steps`` / ``rk4_run``, None when absent); they import
no other module of the project but ``gimbal_reduction.solver.dynamics.exponential`` (and its ``linearized``).
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import DOP853

from gimbal_reduction.solver.dynamics import exponential
from gimbal_reduction.solver.dynamics.kernels import kernel_load_timer
from gimbal_reduction.workflow.progress import Progress

RK4_STABILITY = 2.785          # h * omega_max at RK4's stability limit (real-axis bound)
RK4_DEFAULT_FRACTION = 0.5
MAX_OUTPUT_BYTES = 16 * 2**30   # a run's output arrays (integrate refuses more before allocating)
METHODS = ("exponential", "rk4", "dop853", "generalized-alpha")
# options that belong to one method only (``integrate`` refuses them with another)
METHOD_OPTIONS = {"fraction": ("rk4",), "rtol": ("dop853",), "atol": ("dop853",),
                  "max_step": ("dop853",), "rho_inf": ("generalized-alpha",),
                  **{name: ("exponential",) for name in exponential.ExponentialOptions.__dataclass_fields__
                     if name != "step"}}


class DivergenceError(RuntimeError):
    """The integration blew up (NaN or energy growth)."""


class StepTooLargeError(ValueError):
    """A fixed RK4 step beyond the stability limit."""


def rk4_stability_limit(omega_max):
    """Largest stable RK4 step [s] for a model whose highest kept frequency is omega_max [rad/s]."""
    return np.inf if omega_max <= 0 else RK4_STABILITY / float(omega_max)


def rk4_amplification(z):
    """RK4's amplification factor R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24 (z = h lambda)."""
    return 1 + z * (1 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)))


def rk4_ray_radius(direction):
    """Where the ray r * direction (r > 0; direction complex, |direction| = 1, Re <= 0) first
    leaves RK4's stability region |R(z)| <= 1: the stable h |lambda| of an eigenvalue lambda in
    that direction, at most ``RK4_STABILITY`` (the project's undamped bound, 2.785; the
    region reaches 2 sqrt 2 on the imaginary axis).  A damped mode of ratio zeta has
    direction -zeta + i sqrt(1 - zeta^2): its bound dips to 2.62 at zeta = 0.5, and an
    overdamped one (zeta > 1) has real eigenvalues omega (zeta +- sqrt(zeta^2 - 1)), the
    larger bounding the step at 2.785 / (omega (zeta + sqrt(zeta^2 - 1))).
    Vectorised over ``direction``; first crossing by a scan then bisection."""
    d = np.atleast_1d(np.asarray(direction, complex))
    r = np.linspace(0.0, 3.0, 3001)[1:]
    bad = np.abs(rk4_amplification(np.outer(d, r))) > 1.0 + 1e-12
    first = np.where(bad.any(axis=1), bad.argmax(axis=1), r.size)
    lo = np.where(first > 0, r[np.maximum(first - 1, 0)], 0.0)
    hi = np.where(first < r.size, r[np.minimum(first, r.size - 1)], 3.0)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        out = np.abs(rk4_amplification(mid * d)) > 1.0 + 1e-12
        hi = np.where(out, mid, hi)
        lo = np.where(out, lo, mid)
    return np.minimum(lo, RK4_STABILITY)


def rk4_damped_limit(eigenvalues):
    """Largest stable RK4 step [s] for a linear system with these eigenvalues [1/s] (complex):
    min over lambda != 0 of ``rk4_ray_radius(lambda / |lambda|) / |lambda|`` (inf if none).
    An eigenvalue with a positive real part (an unstable system) has no stable step: 0."""
    lam = np.asarray(eigenvalues, complex).ravel()
    size = np.abs(lam)
    lam = lam[size > 0]
    if lam.size == 0:
        return np.inf
    if np.any(lam.real > 1e-9 * np.abs(lam)):
        return 0.0
    # one representative per conjugate pair (the region is symmetric about the real axis)
    lam = lam[lam.imag >= 0]
    return float(np.min(rk4_ray_radius(lam / np.abs(lam)) / np.abs(lam)))


def rk4_limit(problem):
    """The RK4 stability limit [s] of a problem: ``rk4_stability_limit(problem.omega_max)``,
    and with modal damping the smaller ``rk4_damped_limit`` of its damped linearised chain
    (``problem.damped_spectrum``): damping tilts the eigenvalues off the imaginary axis,
    where RK4's region is narrower (2.62 / omega at an effective zeta of 0.5)."""
    limit = rk4_stability_limit(problem.omega_max)
    damping = getattr(problem, "damping_diagonal", None)
    if damping is not None and np.any(np.asarray(damping) > 0) and hasattr(problem, "damped_spectrum"):
        limit = min(limit, rk4_damped_limit(problem.damped_spectrum))
    return limit


def rk4_limit_reason(problem):
    """A phrase for messages: what sets ``rk4_limit(problem)``."""
    undamped = rk4_stability_limit(problem.omega_max)
    limit = rk4_limit(problem)
    text = f"2.785/omega_max = {undamped:.3e} s (coupled omega_max = {problem.omega_max:.4g} rad/s)"
    if limit < undamped * (1 - 1e-9):
        text = (f"{limit:.3e} s with the modal damping (the damped coupled modes; undamped it "
                f"would be {text})")
    return text


def rk4_step(rhs, t, y, yd, h):
    """One classical RK4 step of the first-order system (y, y')' = (y', rhs)."""
    k1v = rhs(t, y, yd)
    y2, v2 = y + 0.5 * h * yd, yd + 0.5 * h * k1v
    k2v = rhs(t + 0.5 * h, y2, v2)
    y3, v3 = y + 0.5 * h * v2, yd + 0.5 * h * k2v
    k3v = rhs(t + 0.5 * h, y3, v3)
    y4, v4 = y + h * v3, yd + h * k3v
    k4v = rhs(t + h, y4, v4)
    y_new = y + (h / 6.0) * (yd + 2 * v2 + 2 * v3 + v4)
    yd_new = yd + (h / 6.0) * (k1v + 2 * k2v + 2 * k3v + k4v)
    return y_new, yd_new


def rk4_steps(rhs, y, yd, t, h, n):
    """n RK4 steps (``rk4_step``) of rhs from (t, y, y'); returns (y, y')."""
    y, yd = np.array(y, float), np.array(yd, float)
    for i in range(n):
        y, yd = rk4_step(rhs, t + i * h, y, yd, h)
    return y, yd


def rk4_advance(problem, y, yd, t, h, n):
    """n RK4 steps of a problem from (t, y, y'); returns (y, y'): its compiled loop
    (``problem.rk4_steps``) when it has one, else ``rk4_steps`` over ``problem.rhs``."""
    if problem.rk4_steps is not None:
        return problem.rk4_steps(y, yd, t, h, n)
    return rk4_steps(problem.rhs, y, yd, t, h, n)


def generalized_alpha_parameters(rho_inf):
    """(alpha_m, alpha_f, gamma, beta) of Chung & Hulbert for spectral radius rho_inf in [0, 1]."""
    if not 0.0 <= rho_inf <= 1.0:
        raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf}")
    am = (2 * rho_inf - 1) / (rho_inf + 1)
    af = rho_inf / (rho_inf + 1)
    g = 0.5 + af - am
    b = 0.25 * (g + 0.5) ** 2
    return am, af, g, b


@dataclass
class Run:
    """What a run produced: outputs and bookkeeping.  y, yd (T, n): arrays, or for the
    exponential integrator ``exponential.ModalStates`` (the same values, computed when read;
    [:, :4] reads only the gimbal columns)."""
    t: np.ndarray
    y: np.ndarray
    yd: np.ndarray
    method: str
    step: float
    steps: int
    wall_time: float        # [s] the integration, without kernel_load_time
    stats: dict = field(default_factory=dict)
    energy: dict = field(default_factory=dict)   # kinetic, potential, power, input_work at t
    kernel_load_time: float = 0.0   # [s] loading (or compiling) Numba kernels during the run: a
    #                                 process's first run of a kind (``kernels.kernel_load_timer``)


class Monitor:
    """Divergence watch: finite state and bounded energy growth."""

    def __init__(self, problem, growth_factor=1e3, model=""):
        self.problem = problem
        self.growth = growth_factor
        self.model = model
        self.E0 = None
        self.scale = 0.0
        self.work = 0.0
        self.last = None
        self.history = []          # (t, T, U, P, work) at every call (the output samples)

    def record(self, t, energy, info, h, method):
        """Take over the watch of a compiled run (``problem.rk4_run``): energy (T, 4)
        = (T, U, P, work) at the output times t, info = (status, k, E, scale); raises
        the DivergenceError this monitor would have raised at sample k."""
        status, k = int(info[0]), int(info[1])
        self.history = [(float(ti), *map(float, row)) for ti, row in zip(t[:k], energy[:k])]
        if k:
            self.E0 = energy[0, 0] + energy[0, 1]
            self.work = float(energy[k - 1, 3])
            self.last = (float(t[k - 1]), float(energy[k - 1, 2]))
        if status == 1:
            raise DivergenceError(
                f"{method} diverged at t = {t[k]:.6g} s (non-finite state), model {self.model!r}, "
                f"step {h:.3e} s")
        if status == 2:
            raise DivergenceError(
                f"{method} diverged at t = {t[k]:.6g} s (energy {info[2]:.3e} in lbf against a scale "
                f"{info[3]:.3e}), model {self.model!r}, step {h:.3e} s")

    def __call__(self, t, y, yd, h, method):
        # one reduction: a non-finite entry (or an overflowing one: divergence too) makes it so
        if not math.isfinite(float(np.dot(y, y)) + float(np.dot(yd, yd))):
            raise DivergenceError(
                f"{method} diverged at t = {t:.6g} s (non-finite state), model {self.model!r}, "
                f"step {h:.3e} s")
        if hasattr(self.problem, "kinetic_energy"):
            T = self.problem.kinetic_energy(t, y, yd)
            U = self.problem.potential_energy(y)
            E = T + U
        else:
            E, T, U = self.problem.energy(t, y, yd), np.nan, np.nan
        P = self.problem.input_power(t, y, yd)
        if self.E0 is None:
            self.E0 = E
            self.scale = abs(E)
        else:
            t0, P0 = self.last
            self.work += 0.5 * (P + P0) * (t - t0)
        self.last = (t, P)
        self.scale = max(self.scale, abs(self.E0), abs(self.work))
        self.history.append((t, T, U, P, self.work))
        if not np.isfinite(E) or (self.scale > 0 and abs(E) > self.growth * self.scale) or \
                (self.scale == 0 and abs(E) > 0):
            raise DivergenceError(
                f"{method} diverged at t = {t:.6g} s (energy {E:.3e} in lbf against a scale "
                f"{self.scale:.3e}), model {self.model!r}, step {h:.3e} s")
        return E


def check_options(method, step, options):
    """ValueError (one line) on an unknown method or option, an option of another method, or
    bad exponential options (``exponential.ExponentialOptions``); None values count as not given.
    Nothing is computed before this check."""
    if method not in METHODS:
        raise ValueError(f"unknown integrator {method!r}; known: {', '.join(METHODS)}")
    options = {k: v for k, v in options.items() if v is not None}
    for key in options:
        if key not in METHOD_OPTIONS:
            raise ValueError(f"unknown integrator option {key!r}; known: "
                             f"{', '.join(sorted(METHOD_OPTIONS))}")
        if method not in METHOD_OPTIONS[key]:
            raise ValueError(f"option --{key.replace('_', '-')} belongs to "
                             f"{METHOD_OPTIONS[key][0]}, not {method}")
    if method == "exponential":
        exponential.ExponentialOptions(step=step, **options)


def integrate(problem, t_end, output_dt, method="rk4", step=None, growth_factor=1e3,
              y0=None, yd0=None, model="", newton_tol=1e-10, max_newton=12, **options):
    """Integrate ``problem`` (``gimbal_reduction.solver.dynamics.problem.Problem``-like: rhs, residual, solve,
    mass_matrix, energy, input_power, y0, yd0, omega_max, rk4_steps, rk4_run) from t = 0 to
    t_end, returning outputs every output_dt.  See the module docstring for the methods.

    Method options (``METHOD_OPTIONS``; an option of another method is refused): rk4
    ``fraction``; dop853 ``rtol`` (1e-10), ``atol`` (1e-14), ``max_step``;
    generalized-alpha ``rho_inf`` (0.9); exponential: the fields of
    ``exponential.ExponentialOptions`` but ``step`` (``tol``, ``relinearise_every`` [s] (fixed
    step only), ``drift`` [rad], ``order``, ``relinearise``, ``evaluate_accepted``, ...).  An
    option given as None counts as not given."""
    if method not in METHODS:
        raise ValueError(f"unknown integrator {method!r}; known: {', '.join(METHODS)}")
    options = {k: v for k, v in options.items() if v is not None}
    check_options(method, step, options)
    if not (np.isfinite(t_end) and t_end >= 0):
        raise ValueError(f"duration must be finite and >= 0, got {t_end}")
    if not (np.isfinite(output_dt) and output_dt > 0):
        raise ValueError(f"output interval must be finite and > 0, got {output_dt}")
    samples = t_end / output_dt + 1
    n_y = np.size(problem.y0 if y0 is None else y0)
    if samples * (2 * n_y + 6) * 8 > MAX_OUTPUT_BYTES:
        raise ValueError(f"{t_end:g} s every {output_dt:g} s is {samples:.3g} output samples "
                         f"(~{samples * (2 * n_y + 6) * 8 / 2**30:.3g} GiB): above the "
                         f"{MAX_OUTPUT_BYTES / 2**30:g} GiB the outputs may take; a longer output interval")
    n_out = max(int(round(t_end / output_dt)), 1) if t_end > 0 else 0
    dt_out = t_end / n_out if n_out else output_dt
    t_out = np.linspace(0.0, t_end, n_out + 1)
    y = np.array(problem.y0 if y0 is None else y0, float)
    yd = np.array(problem.yd0 if yd0 is None else yd0, float)
    monitor = Monitor(problem, growth_factor, model)
    Y = np.empty((t_out.size, y.size))
    V = np.empty_like(Y)
    Y[0], V[0] = y, yd
    # the whole RK4 run compiled, energy watch included (compiled path, constant torques)
    whole_run = method == "rk4" and problem.rk4_run is not None
    if not whole_run and not (method == "exponential" and step is None):
        monitor(0.0, y, yd, 0.0, method)
    start = time.perf_counter()
    out = _Outputs(t_out, dt_out, Y, V, monitor, method, model)
    with kernel_load_timer() as load:
        if method == "exponential":
            h, steps, stats = _exponential(problem, out, step, options)
        elif method == "rk4":
            h, steps, stats = _rk4(problem, out, step, options.get("fraction"), growth_factor, whole_run)
        elif method == "dop853":
            h, steps, stats = _dop853(problem, out, step, options.get("rtol", 1e-10),
                                      options.get("atol", 1e-14), options.get("max_step", np.inf))
        else:
            h, steps, stats = _generalized_alpha(problem, out, step, options.get("rho_inf", 0.9),
                                                 newton_tol, max_newton)
    wall = time.perf_counter() - start - load.seconds
    if monitor.history:
        stats["energy_input"] = monitor.work
    hist = np.array(monitor.history)
    energy = {} if hist.shape[0] != t_out.size else {
        "kinetic": hist[:, 1], "potential": hist[:, 2], "power": hist[:, 3], "input_work": hist[:, 4]}
    return Run(t=t_out, y=out.Y, yd=out.V, method=method, step=float(h), steps=int(steps),
               wall_time=wall, stats=stats, energy=energy, kernel_load_time=load.seconds)


# A run longer than this prints a progress line (stderr, the job's log) this often [s]: the
# simulated time reached and the wall time left at the mean rate so far (gimbal_reduction.workflow.progress)
PROGRESS_EVERY = 30.0


@dataclass
class _Outputs:
    """What the three methods share: output times t (T,), their spacing dt, the state
    rows Y, V (T, n) to fill (row 0 holds the initial state), the monitor, and the names
    for messages."""
    t: np.ndarray
    dt: float
    Y: np.ndarray
    V: np.ndarray
    monitor: Monitor
    method: str
    model: str

    progress: Progress = None

    def __post_init__(self):
        self.progress = Progress(f"{self.method} {self.model}", float(self.t[-1]), "s",
                                 every=PROGRESS_EVERY)

    def store(self, k, y, yd, h):
        """Watch sample k (``Monitor``), then keep it; report progress every PROGRESS_EVERY s
        (simulated time of the whole; none at the first and the last sample)."""
        self.monitor(self.t[k], y, yd, h, self.method)
        self.Y[k], self.V[k] = y, yd
        if 0 < k < self.t.size - 1:
            self.progress.update(float(self.t[k]))


def _exponential(problem, out, step, options):
    """The modal exponential integrator (``exponential.ExponentialAdams``); (h, steps, stats),
    h the largest step taken."""
    settings = exponential.ExponentialOptions(step=step, **options)
    integrator = exponential.ExponentialAdams(problem, settings, model=out.model)
    # adaptive: the error control watches the run, the energy is not sampled (Run.energy
    # stays empty; simulate.energy_history computes it afterwards); fixed step: the monitor
    watch = step is not None

    def on_outputs(ks, Y, V, h):
        for k, y, yd in zip(ks, Y, V):
            out.store(k, y, yd, h)
    st, out.Y, out.V = integrator.run(out.t, out.Y[0].copy(), out.V[0].copy(),
                                      on_outputs if watch else None)
    return st.largest_step, st.steps, {
        "tol": integrator.tol if integrator.tol is not None else np.nan,
        "order": integrator.order, "drift": integrator.drift, **settings.attributes(),
        "evaluations": st.evaluations, "rejected": st.rejected,
        "relinearisations": st.relinearisations, "basis_time_s": st.basis_time,
        "first_basis_time_s": st.first_basis_time, "weight_sets": st.weight_sets,
        "phase_relinearisations": st.phase_relinearisations, "frequency_updates": st.frequency_updates,
        "smallest_step": st.smallest_step, "largest_step": st.largest_step,
        "coupled_omega_max": st.coupled_omega_max}


def _rk4(problem, out, step, fraction, growth_factor, whole_run):
    """Classical RK4 at a fixed step (module docstring); (h, steps, stats)."""
    t_out, dt_out, model = out.t, out.dt, out.model
    y, yd = out.Y[0].copy(), out.V[0].copy()
    limit = rk4_limit(problem)
    if step is None:
        frac = RK4_DEFAULT_FRACTION if fraction is None else fraction
        h_req = frac * limit if np.isfinite(limit) else dt_out
    else:
        h_req = float(step)
    if not (h_req > 0):
        raise StepTooLargeError(f"rk4 step must be > 0, got {h_req}")
    if h_req > limit * (1 + 1e-12):
        raise StepTooLargeError(
            f"rk4 step {h_req:.3e} s exceeds the stability limit {rk4_limit_reason(problem)} "
            f"of model {model!r}")
    n_sub = max(int(np.ceil(dt_out / h_req - 1e-9)), 1)
    h = dt_out / n_sub
    steps = 0
    if whole_run:
        out.Y, out.V, energy, info = problem.rk4_run(y, yd, t_out, h, n_sub, growth_factor)
        steps = n_sub * max(int(info[1]) - 1, 0)
        out.monitor.record(t_out, energy, info, h, out.method)
    else:
        for k in range(1, t_out.size):
            y, yd = rk4_advance(problem, y, yd, t_out[k - 1], h, n_sub)
            steps += n_sub
            out.store(k, y, yd, h)
    return h, steps, {"stability_limit": limit,
                      "fraction": h / limit if np.isfinite(limit) else 0.0}


def _dop853(problem, out, step, rtol, atol, max_step):
    """scipy's DOP853 in one run over the whole window (module docstring); (h, steps, stats),
    h the smallest step taken.

    The method chooses its own steps; an output time inside a step is read from that step's
    dense output (the method's continuous extension, of order 7: its error is of the size of
    the step's own), the last one is the run's end point.  Restarting the method at every
    output time instead (an initial-step search, 2 evaluations, and a step no longer than the
    output interval each time) cost 2.2x the evaluations on a 100-mode model of the thesis
    scene at rtol 1e-6, for the same motion to its tolerance."""
    t_out, model = out.t, out.model
    n = out.Y.shape[1]

    def f(t, z):
        a = problem.rhs(t, z[:n], z[n:])
        return np.concatenate([z[n:], a])
    solver = DOP853(f, float(t_out[0]), np.concatenate([out.Y[0], out.V[0]]), float(t_out[-1]),
                    rtol=rtol, atol=np.full(2 * n, atol), max_step=max_step,
                    first_step=None if step is None else step)
    h = np.inf
    steps = 0
    k = 1
    while k < t_out.size:
        message = solver.step()
        if solver.status == "failed":
            raise DivergenceError(f"dop853 failed at t = {solver.t:.6g} s: {message}, "
                                  f"model {model!r}")
        steps += 1
        h = min(h, solver.step_size)
        if t_out[k] <= solver.t:
            dense = solver.dense_output()
            while k < t_out.size and t_out[k] <= solver.t:
                z = solver.y if t_out[k] == solver.t else dense(t_out[k])
                out.store(k, z[:n], z[n:], h)
                k += 1
    t_end = t_out[-1]
    return h, steps, {"rtol": rtol, "atol": atol, "smallest_step": h,
                      "mean_step": t_end / max(steps, 1)}


def _generalized_alpha(problem, out, step, rho_inf, newton_tol, max_newton):
    """Implicit generalised-alpha with Newton iterations (module docstring); (h, steps, stats)."""
    t_out, dt_out = out.t, out.dt
    y, yd = out.Y[0].copy(), out.V[0].copy()
    h = float(step) if step is not None else dt_out
    n_sub = max(int(np.ceil(dt_out / h - 1e-9)), 1)
    h = dt_out / n_sub
    am, af, g, b = generalized_alpha_parameters(rho_inf)
    beta_p = h * h * b * (1 - af) / (1 - am)
    gamma_p = h * g * (1 - af) / (1 - am)
    d_modal = 1.0 + gamma_p * problem.damping_diagonal[4:] + beta_p * problem.stiffness_diagonal[4:]
    acc = problem.rhs(0.0, y, yd)
    a_pseudo = acc.copy()
    steps = 0
    iterations = 0
    worst_newton = 0
    for k in range(1, t_out.size):
        t0 = t_out[k - 1]
        for i in range(n_sub):
            t1 = t0 + (i + 1) * h
            A = acc.copy()
            for it in range(max_newton):
                a_new = (af * acc + (1 - af) * A - am * a_pseudo) / (1 - am)
                y1 = y + h * yd + h * h * ((0.5 - b) * a_pseudo + b * a_new)
                v1 = yd + h * ((1 - g) * a_pseudo + g * a_new)
                R = problem.residual(t1, y1, v1, A)
                dA = problem.solve(y1, -R, d_modal)
                A = A + dA
                iterations += 1
                if np.abs(dA).max() <= newton_tol * max(np.abs(A).max(), 1e-300):
                    break
            else:
                worst_newton += 1
            a_new = (af * acc + (1 - af) * A - am * a_pseudo) / (1 - am)
            y = y + h * yd + h * h * ((0.5 - b) * a_pseudo + b * a_new)
            yd = yd + h * ((1 - g) * a_pseudo + g * a_new)
            acc, a_pseudo = A, a_new
        steps += n_sub
        out.store(k, y, yd, h)
    return h, steps, {"rho_inf": rho_inf, "newton_iterations": iterations,
                      "newton_per_step": iterations / max(steps, 1),
                      "newton_not_converged": worst_newton}

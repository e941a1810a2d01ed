"""Verified search: the smallest pooled set that meets a tolerance, judged by simulation.

``tol-EPS`` (``gimbal_reduction.reduction.models``) picks the smallest pooled load-aware set ``global-N`` whose
a-priori estimate of eq. 3.53 is within EPS.  The estimate is the frozen linear chain's
(``gimbal_reduction.reduction.frozen_chain``), and where a scene moves the gimbals too far or too fast for it
(``FROZEN_ANGLE``, ``FROZEN_RATE``) it is no promise.  There the selection falls back to this
search: it simulates candidate sets against the truth and keeps the smallest that passes.

**Candidates and the test.**  The candidates are the prefixes of the pooled ranking, global-N
for N = 0..Q (Q: every computed mode of every body).  Each is integrated through the scene with
the project's default integrator (``gimbal_reduction.solver.dynamics.simulate.DEFAULT_INTEGRATOR``: the modal
exponential integrator at its default tolerance) and judged against the truth integrated the
same way, with eq. 3.53 on each of the four gimbal rates n:

    pass(N)  <=>  max_n E_n(global-N) <= EPS,    E_n = int (x_n - r_n)^2 dt / int r_n^2 dt .

global-Q keeps exactly the truth's modes, so E(Q) = 0 by identity (it is not simulated).

**With an attitude request** (``tol-EPS-att-A``) the platform's attitude error against the
truth's, the largest angle between the two platform frames over the window [arcsec], must also be
<= A: the measured vector has a fifth entry and its own limit.

**The search.**  E(N) does not fall monotonically with N (a kept mode can add ringing:
docs/selection.md Section 1), so nothing short of simulating every N finds the smallest passing N
for certain.  The search keeps a bracket: ``fail``, the largest N simulated and failing below the
answer (-1: none yet), and ``ok``, the smallest N known to pass (Q at the start):

1. a first probe at a guess g (the frozen chain's own choice: a hint where it is no promise),
   then galloping from g with steps 1, 2, 4, ... towards the answer until the outcome flips
   (downwards while probes pass, upwards while they fail);
2. bisection of (fail, ok) until ok = fail + 1.

The answer ok has been simulated and passes, and global-(ok - 1) has been simulated and fails
(or ok = 0, the rigid model).  Without a guess the search costs ceil(log2(Q + 1)) probes (9 for
Q = 400); with a guess at distance d from the answer, about 2 log2(d) + 2.  A smaller N that was
never probed may pass too (E is not monotone); every probe is returned, and the reduced-model
file records them (``tol_search_N``, ``tol_search_E_max``).

Only the pure search (``smallest_verified``) and the judge (``SimulationJudge``) live here; the
candidates' chains come from a callable, so this module imports no reduction module.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from gimbal_reduction.solver.dynamics import integrators, simulate
from gimbal_reduction.solver.dynamics.error_measure import ARCSEC_PER_RAD, attitude_error, error_measure

N_RATES = 4
# what every candidate and the truth are integrated with: the project's default (the modal
# exponential integrator at its default tolerance, docs/exponential.md)
INTEGRATOR = f"{simulate.DEFAULT_INTEGRATOR} (default tolerance)"


class SearchError(ValueError):
    """A verified search that cannot run (one-line message)."""


@dataclass
class SearchResult:
    """The answer of ``smallest_verified``: N, its E (4,), and every probe in the order made:
    probes [(N, E (4,))] (the known values given to the search come first)."""
    N: int
    E: np.ndarray
    probes: list = field(default_factory=list)

    @property
    def probe_N(self):
        return np.array([n for n, _ in self.probes], dtype=int)

    @property
    def probe_E_max(self):
        """Largest gimbal-rate E of every probe (k,)."""
        return np.array([float(np.max(e[:N_RATES])) for _, e in self.probes])

    @property
    def probe_attitude(self):
        """Attitude error [arcsec] of every probe (k,) (NaN where not measured)."""
        return np.array([float(e[N_RATES]) if e.size > N_RATES else np.nan for _, e in self.probes])


def smallest_verified(eps, measure, total, guess=None, known=None) -> SearchResult:
    """The smallest N in 0..total found passing, E(N) <= eps entry by entry, with N - 1 found
    failing.

    measure(N) -> E (k,): eq. 3.53 per gimbal rate (k = 4), and with an attitude request the
    platform's attitude error [arcsec] as a fifth entry; inf or NaN fails.  eps: the limit, one
    number for every entry or one per entry (k,).  total: the largest candidate, which passes by
    assumption if it is not in ``known`` and never needs measuring to start the bracket (it is
    measured only if the search ends there and it is not known); guess: the first probe (None:
    plain bisection); known: {N: E} already known (not measured again).  ``SearchResult.probes``
    and ``probe_E_max`` hold the whole vectors and their largest gimbal-rate E.  Pure apart from
    the calls to ``measure``."""
    limits = np.atleast_1d(np.asarray(eps, float))
    if not np.all(np.isfinite(limits)) or np.any(limits <= 0):
        raise SearchError(f"verified search: the tolerance must be positive and finite, got {eps}")
    total = int(total)
    if total < 0:
        raise SearchError(f"verified search: no candidates (total {total})")
    values = {}
    probes = []

    def E_of(N):
        if N not in values:
            E = np.atleast_1d(np.asarray(known[N] if known and N in known else measure(N), float))
            values[N] = E
            probes.append((N, E))
        return values[N]

    def passes(N):
        E = E_of(N)
        return bool(np.all(np.isfinite(E)) and np.all(E <= limits))

    for N in sorted(known or {}):                      # known values come first in the record
        if 0 <= N <= total:
            E_of(N)
    fail, ok = -1, total
    if guess is not None:
        g = int(min(max(int(guess), 0), total))
        if g < total:
            step = 1
            if passes(g):
                ok = g
                while ok - step > fail:                # gallop down while probes pass
                    n = ok - step
                    if passes(n):
                        ok = n
                        step *= 2
                    else:
                        fail = n
                        break
            else:
                fail = g
                while fail + step < ok:                # gallop up while probes fail
                    n = fail + step
                    if passes(n):
                        ok = n
                        break
                    fail = n
                    step *= 2
    while ok - fail > 1:                               # bisection of the bracket
        mid = (fail + ok) // 2
        if passes(mid):
            ok = mid
        else:
            fail = mid
    if ok == total and ok not in values:
        E_of(total)
    return SearchResult(N=ok, E=values[ok], probes=probes)


# ------------------------------------------------------------------ the simulation judge
class Runs:
    """The simulations of the judges one caller makes: key -> {"truth": (t, rates, frames, s),
    N: (E, s)}, so that several requests on one scene (``gimbal_reduction.results.bench.tolerance``)
    simulate each candidate once.  Passed to each ``SimulationJudge``; nothing is kept elsewhere.

    truth: (t (T,) [s], rates (T, 4) [rad/s], platform frames (T, 3, 3), wall time [s]) of the
    scene's truth the caller has already integrated with the default integrator (every mode of the
    scene's elastic bodies, the same body files: the set global-Q keeps, in another order); each
    judge takes it as its truth's run instead of simulating global-Q again."""

    def __init__(self, truth=None):
        self._by_key = {}
        self.truth = truth

    def of(self, key):
        """The runs kept under ``key`` (a dict the judge fills)."""
        return self._by_key.setdefault(key, {})


class SimulationJudge:
    """measure(N) for ``smallest_verified``: E (4,) of global-N against the truth, each integrated
    through ``scene`` with the default integrator (``gimbal_reduction.solver.dynamics.simulate.run_scene``); with
    ``attitude`` also the platform's attitude error against the truth's (5,): the largest angle
    over the window between the two platform frames [arcsec] (``error_measure.attitude_error``,
    the tables' ``attitude_max_arcsec``).

    chain_for(N) -> multibody.Chain of the candidate global-N (scene damping included);
    truth_N: the count whose chain is the truth's (its E is 0 by identity); key: a hashable
    naming everything the runs depend on (scene physics, body files, ranking), under which the
    truth's run and every candidate's E are kept in ``runs`` (a ``Runs`` the caller keeps across
    judges: several EPS on one scene, ``gimbal_reduction.results.bench.tolerance``, simulate each N
    once; None: this judge's own).  A candidate
    whose integration diverges fails (E = inf).  log(text): one line per simulation."""

    def __init__(self, scene, chain_for, truth_N, key=None, log=None, attitude=False, runs=None):
        self.scene, self.chain_for, self.truth_N = scene, chain_for, int(truth_N)
        self.size = N_RATES + 1 if attitude else N_RATES
        self.log = log or (lambda text: None)
        self.runs = runs.of(key) if runs is not None and key is not None else {}
        if runs is not None and runs.truth is not None and "truth" not in self.runs:
            self.runs["truth"] = runs.truth
            self.log(f"truth (global-{self.truth_N}): the caller's run of it, "
                     f"{runs.truth[-1]:.1f} s, not simulated again")
        self.seconds = 0.0          # wall time of the simulations this judge ran itself

    def _run(self, N):
        """(t (T,) [s], gimbal rates (T, 4) [rad/s], platform frames (T, 3, 3), wall time [s])."""
        t0 = time.perf_counter()
        chain = self.chain_for(N)
        run, _ = simulate.run_scene(chain, self.scene, model_name=f"global-{N}")
        wall = time.perf_counter() - t0
        self.seconds += wall
        return (np.asarray(run.t, float), np.asarray(run.yd[:, :N_RATES], float),
                simulate.platform_attitude(chain, run), wall)

    def truth(self):
        """(t (T,) [s], gimbal rates (T, 4) [rad/s], platform frames (T, 3, 3), wall time [s]) of
        the truth's run."""
        if "truth" not in self.runs:
            self.runs["truth"] = self._run(self.truth_N)
            self.log(f"truth (global-{self.truth_N}) simulated in {self.runs['truth'][-1]:.1f} s")
        return self.runs["truth"]

    def __call__(self, N):
        N = int(N)
        if N == self.truth_N:
            return np.zeros(self.size)
        if N not in self.runs:
            t, reference, frames, _ = self.truth()
            try:
                _, rates, frames_N, wall = self._run(N)
                E = np.append(np.asarray(error_measure(t, reference, rates), float),
                              float(np.max(attitude_error(frames, frames_N))) * ARCSEC_PER_RAD)
            except integrators.DivergenceError as exc:
                E, wall = np.full(N_RATES + 1, np.inf), float("nan")
                self.log(f"global-{N} diverged ({' '.join(str(exc).split())[:120]}): fails")
            self.runs[N] = (E, wall)
            self.log(f"global-{N}: max E {np.max(E[:N_RATES]):.3e}, attitude {E[N_RATES]:.3g} arcsec "
                     f"in {wall:.2f} s")
        return self.runs[N][0][:self.size]

    def wall_time(self, N):
        """Wall time [s] of candidate N's simulation (NaN if not simulated in this process)."""
        entry = self.runs.get("truth" if N == self.truth_N else int(N))
        return float(entry[-1]) if entry else float("nan")


"""Reduced models named by compact strings, and their assembly from the body files.

A name is read by ``gimbal_reduction.reduction.names`` (its grammar, ``names.parse``); this
module says what the parsed name keeps (``model_spec``: ``select_modes`` for the mode families,
``resolve_tolerance`` for a tol- request) and builds the chain.  What the names mean:

* ``truth``: the 100 lowest-frequency vibration modes of every body (thesis).
* ``rigid``: no elastic modes (the rigid limit).
* ``freq-10`` / ``xmx-10`` / ``xmgmx-10``: the 10 first modes of every body in the
  frequency / XMX / XMGMX ranking (``rank_frequency`` ... of
  results/reduction/body{n}.h5, 0-based, most important first);
  ``freq-10,10,5,5`` keeps 10, 10, 5, 5 on bodies 2..5.
* ``static-8`` (= ``static-freq-8``): the 8 lowest modes plus one static
  correction mode per body with the default load case (``output_motor_fz`` for
  bodies 2-4, as the thesis's Figure 4-12; ``input_motor_fx`` for the platform,
  which has no output bearings **[chosen]**); ``static-xmx-8`` with XMX-ranked modes.
* ``load-10`` / ``load-10,10,5,5``: the first modes of every body in the scene's
  load-aware ranking (``rank_load`` of results/reduction/load/{scene}.h5, written by
  ``python -m gimbal_reduction.reduction.load_aware``; docs/selection.md): the modes ranked by what
  the scene's joint loads make them contribute to the gimbal rates.
* ``global-40``: 40 vibration modes in total, the first 40 of the pooled load-aware
  ranking of all four bodies' modes (thesis Section 5.1), however they fall on
  the bodies (``pooled/body``, ``pooled/mode`` of the same file).
  ``load-*`` and ``global-*`` need the scene's ranking file (``names.needs_load_ranking``,
  ``load_load_ranking``; ``simulate --load-ranking``).
* ``dom-10``: the 10 first modes of every body in the dominance ranking (``rank_dominance``
  of the reduction stage's files; ``gimbal_reduction.reduction.bases``).
* ``cb-10`` / ``cb-10,10,10,20``: orthonormalised Craig-Bampton: on each ring the 10 lowest
  fixed-interface modes and the 6 constraint modes of its output interface, Rayleigh-Ritz
  orthonormalised (16 coordinates; from the ring's Craig-Bampton stage file
  results/reduction/cb/body{n}.h5, ``gimbal_reduction.reduction.bases``); on the platform, which
  has no output interface, its 10 lowest supported modes.
* ``ritz-10``: 10 load-dependent Ritz vectors per body, Rayleigh-Ritz orthonormalised, computed
  from the body file (``bases.ritz_basis``).  cb- and ritz- bodies keep no body-file mode
  (``kept`` is empty in the model file); their coordinates are named ``cb i`` / ``ritz i``.
* ``tol-EPS`` (e.g. ``tol-1e-4``, ``tol-0.001``): accuracy on request.  The smallest
  pooled set ``global-N`` whose a-priori estimate of eq. 3.53 (the frozen linear chain of
  ``gimbal_reduction.reduction.load_aware``: ``estimate/global`` of the scene's ranking file for N = 1..pool,
  ``estimate/rigid`` for N = 0, and beyond the pool the same estimator evaluated on the
  file's ``linear/*`` chain) is <= EPS on every one of the four gimbal rates
  (``tolerance_choice``).  Refused with a one-line ModelError when no N up to the computed
  modes meets EPS (the message gives the smallest estimate reached).  Where the scene moves
  the gimbals too far or too fast for the frozen chain (the ranking file's
  ``angle_excursion_rad`` above ``frozen_chain.FROZEN_ANGLE`` or
  ``rate_over_lowest_frequency`` above ``FROZEN_RATE``: scenes ``long``, ``spin``), the
  estimate would be a promise it cannot keep: ``reduce_model`` says so and falls back to a
  **verified search** (``gimbal_reduction.reduction.verified_search``): candidate global-N are simulated
  against the truth with the default integrator, and the smallest N found passing (measured
  max E <= EPS, with global-(N - 1) measured failing) is taken; refused in one line if only
  the truth itself passes.  ``model_spec`` alone (no scene, no simulation) and
  ``--no-verified-search`` refuse instead (FrozenChainInvalid).  ``tol-EPS-att-A``
  (e.g. ``tol-1e-4-att-2``) also asks that the stable platform's attitude error against the
  truth, the largest angle between the two platform frames over the window, be at most A
  arcsec (the tables' ``attitude_max_arcsec``); the frozen chain estimates the rates only, so
  this is always a verified search (AttitudeRequested), its first guess the rates' a-priori
  choice.  No static modes (``@``) are taken.  The choice (N, how it was made, the estimate per rate, the measured E of a
  verified search and its probes) is recorded in the reduced-model file's attributes
  ``tol_*`` (docs/models.md).
* ``@body:case`` puts static modes on the listed bodies only, e.g.
  ``static-10@2:output_motor_fz`` (outer gimbal only) or
  ``freq-6@2:output_motor_fz+output_motor_my@3:output_motor_fz``.

``names.parse`` is a pure function of the name; ``model_spec`` of the name and the
rankings (for a tol- request the a-priori estimates: ``resolve_tolerance``; the verified
search is ``resolve_verified``, run by ``reduce_model``).  Bad names, counts above what was
computed and malformed load cases raise ModelError with a one-line message, before anything is
integrated.
"""

import functools
import hashlib
import json
import os
import sys
import time

import h5py
import numpy as np

from gimbal_reduction.reduction import bases, frozen_chain, modal_integrals, names, verified_search
from gimbal_reduction.reduction.names import DEFAULT_LOAD_CASE, TRUTH_MODES, ModelError, ModelName
from gimbal_reduction.reduction.selection import (LOAD_KEY, OPTIONAL_RANKING_KEYS, POOLED_KEY, RANKING_KEYS,
                                                  TOL_FAMILY, TOL_FLOOR,
                                                  ModelSpec, check_name, check_tolerance,
                                                  identity_rankings, pooled_kept, select_modes)
from gimbal_reduction.reduction.static_modes import load_case_vector, static_correction_modes
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.bodydata import BODIES, BEARING_NAMES, check_config_hash, read_body_file
from gimbal_reduction.solver.dynamics import chainfile, multibody, scenes
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow.provenance import content_problem, versions

TOL_COARSE = 8          # beyond the stored estimates: scan N in steps of 8, then refine the bracket
BEARINGS = BEARING_NAMES
TOL_APRIORI, TOL_VERIFIED = "a-priori estimate", "verified search"


class NeedsSimulation(ModelError):
    """A tol- request the frozen-chain estimate cannot answer: ``reason`` says why, ``eps`` is the
    request (``reduce_model`` answers it by verified search instead)."""

    def __init__(self, message, reason="", eps=None):
        super().__init__(message)
        self.reason, self.eps = reason, eps


class FrozenChainInvalid(NeedsSimulation):
    """tol-EPS on a scene where the frozen-chain estimate does not hold."""


class AttitudeRequested(NeedsSimulation):
    """tol-EPS-att-A: the frozen chain gives the gimbal rates only, no attitude estimate."""


def model_spec(name, rankings):
    """ModelSpec of a model name (or ModelName) from the rankings: ``names.parse``, then
    ``select_modes``, or for a tol- request ``resolve_tolerance`` (the a-priori choice; raises
    NeedsSimulation where only a verified search can answer).

    rankings: {body: {"rank_frequency": (D,), "rank_xmx": (D,), "rank_xmgmx": (D,)}}
    (0-based mode indices, most important first; D = computed modes)."""
    parsed = name if isinstance(name, ModelName) else names.parse(name)
    if parsed.family == TOL_FAMILY:
        return resolve_tolerance(parsed, rankings)
    return select_modes(parsed, rankings)


def frozen_chain_valid(pooled):
    """(ok, reason): whether the scene's frozen-linear-chain estimate holds, from the ranking
    file's attributes (the same test as ``gimbal_reduction.reduction.load_aware``'s warning)."""
    exc = np.asarray(pooled.get("angle_excursion", np.zeros(4)), float)
    rate = float(pooled.get("rate_over_lowest_frequency", 0.0))
    if exc.size and np.max(exc) > frozen_chain.FROZEN_ANGLE:
        return False, (f"the gimbals move {np.max(exc):.2e} rad > {frozen_chain.FROZEN_ANGLE:g} rad "
                       f"(frozen_chain.FROZEN_ANGLE)")
    if rate > frozen_chain.FROZEN_RATE:
        return False, (f"rate / lowest modal frequency {rate:.1e} > {frozen_chain.FROZEN_RATE:g} "
                       f"(frozen_chain.FROZEN_RATE)")
    return True, ""


@functools.lru_cache(maxsize=4)
def _linear_chain(path, mtime_ns):
    """(frozen linear chain decimated to the stored curves' grid, pooled order (Q,) as indices
    into its coordinates) of the ranking file ``path`` as of ``mtime_ns`` (the file's
    modification time: a rewritten file is read again).  Read-only."""
    model = frozen_chain.read_linear_model(path)
    stride = max(1, int(np.ceil(len(model["t"]) / frozen_chain.CURVE_SAMPLES)))
    model = frozen_chain.decimated(model, stride)
    with h5py.File(path, "r") as f:
        body, mode = np.asarray(f["pooled/body"][()], int), np.asarray(f["pooled/mode"][()], int)
    return model, np.asarray(model["offsets"], int)[body - 2] + mode


@functools.lru_cache(maxsize=1024)
def _linear_estimate(path, mtime_ns, N):
    """A-priori E (4,) of the pooled top N of ranking file ``path`` (as of ``mtime_ns``) by
    ``frozen_chain.estimate_error`` on its frozen linear chain.  Read-only."""
    model, order = _linear_chain(path, mtime_ns)
    return np.asarray(frozen_chain.estimate_error(model, order[:N]), float)


def _extended_estimate(pooled, N):
    """A-priori E (4,) of the pooled top N beyond the stored curve: ``frozen_chain.estimate_error``
    on the ranking file's frozen linear chain, on the grid the stored curves use."""
    if not pooled.get("path"):
        raise ModelError("tol-EPS: the ranking's frozen linear chain is not available")
    path, mtime_ns = pooled["path_key"]
    return _linear_estimate(path, mtime_ns, int(N))


def tolerance_choice(eps, pooled, total, extend=None, check_valid=True):
    """(N, E (4,), source): the smallest pooled count N (0..total) whose a-priori estimate is
    <= eps on every gimbal rate.  pooled: rankings["pooled"] with ``estimate`` (P, 4) of
    N = 1..P and ``rigid_estimate`` (4,) of N = 0; beyond P, extend(N) -> E (4,) (None: stop
    at P), scanned in steps of TOL_COARSE, then every N of the bracket that met eps.
    FrozenChainInvalid (one line) if the frozen chain is flagged invalid (check_valid=False:
    the estimate's choice all the same, the verified search's first guess); ModelError (one
    line) if no N meets eps."""
    ok, why = frozen_chain_valid(pooled)
    if check_valid and not ok:
        raise FrozenChainInvalid(
            f"tol-{eps:g}: refused on scene {pooled.get('scene', '?')!r}: {why}; the "
            f"frozen-linear-chain estimate cannot promise E <= {eps:g} (gimbal_reduction.reduction.models answers "
            f"by verified search unless --no-verified-search; or check a global-N against the truth)",
            reason=why, eps=eps)
    est = pooled.get("estimate")
    if est is None:
        raise ModelError(f"tol-{eps:g}: the ranking file holds no a-priori estimates "
                         f"(estimate/global): rerun python -m gimbal_reduction.reduction.load_aware")
    est = np.asarray(est, float).reshape(-1, 4)
    curve = [np.asarray(pooled.get("rigid_estimate", np.full(4, np.inf)), float)] + list(est)
    best = min(float(np.max(c)) for c in curve)
    for N, E in enumerate(curve[:total + 1]):
        if np.max(E) <= eps:
            return N, E, "ranking file estimate/global" if N else "ranking file estimate/rigid"
    P = len(curve) - 1
    if extend is not None and P < total:
        lo = P
        for hi in list(range(P + TOL_COARSE, total, TOL_COARSE)) + [total]:
            E_hi = extend(hi)
            best = min(best, float(np.max(E_hi)))
            if np.max(E_hi) <= eps:
                for N in range(lo + 1, hi):
                    E = extend(N)
                    if np.max(E) <= eps:
                        return N, E, "frozen linear chain of the ranking file (N > pool)"
                return hi, E_hi, "frozen linear chain of the ranking file (N > pool)"
            lo = hi
    reached = P if extend is None else total
    raise ModelError(f"tol-{eps:g}: no pooled set of up to {reached} modes meets E <= {eps:g} "
                     f"on every gimbal rate (smallest estimate reached {best:.3e})")


def _pooled_rankings(name, rankings):
    """(pooled ranking, {body: computed modes}, total) of a tol- request; ModelError if the
    pooled ranking is not loaded."""
    pooled = rankings.get(POOLED_KEY)
    if pooled is None:
        raise ModelError(f"model {name!r}: no pooled load-aware ranking loaded (python -m "
                         f"gimbal_reduction.reduction.load_aware; simulate --load-ranking PATH)")
    available = {b: len(np.asarray(rankings[b]["rank_frequency"])) for b in BODIES}
    return pooled, available, sum(available.values())


def resolve_tolerance(parsed, rankings):
    """ModelSpec of a tol- request (a parsed name) by the a-priori estimate: global-N with N from
    ``tolerance_choice``, the choice in ``spec.choice``.  NeedsSimulation where the estimate
    cannot answer (the frozen chain does not hold on the scene, or the attitude is asked):
    ``resolve_verified`` answers it."""
    name, eps = parsed.name, parsed.eps
    pooled, available, total = _pooled_rankings(name, rankings)
    N, E, source = tolerance_choice(eps, pooled, total,
                                    extend=(lambda n: _extended_estimate(pooled, n))
                                    if pooled.get("path") else None)
    if parsed.attitude is not None:
        raise AttitudeRequested(
            f"tol-{eps:g}: the platform attitude has no a-priori estimate (the frozen chain gives the "
            f"gimbal rates only): gimbal_reduction.reduction.models answers {name} by verified search (simulations)",
            reason="the platform attitude has no a-priori estimate (the frozen chain gives the gimbal "
                   "rates only)", eps=eps)
    kept = pooled_kept(name, N, rankings, available)
    choice = {"tol_eps": eps, "tol_N": int(N), "tol_method": TOL_APRIORI,
              "tol_estimate": np.asarray(E, float), "tol_estimate_max": float(np.max(E)),
              "tol_estimate_source": source, "tol_frozen_chain_valid": 1,
              "tol_equivalent_model": f"global-{N}"}
    return ModelSpec(name=name, kept=kept, static=dict.fromkeys(BODIES, ()), ranking=TOL_FAMILY,
                     choice=choice)


def apriori_estimate(pooled, N):
    """(E (4,), source) of the pooled top N by the frozen chain: the ranking file's stored
    curve (N <= pool), else the estimator on its frozen linear chain; (None, reason) if neither."""
    N = int(N)
    est = pooled.get("estimate")
    if N == 0 and pooled.get("rigid_estimate") is not None:
        return np.asarray(pooled["rigid_estimate"], float), "ranking file estimate/rigid"
    if est is not None and 0 < N <= len(est):
        return np.asarray(est, float).reshape(-1, 4)[N - 1], "ranking file estimate/global"
    if pooled.get("path"):
        return _extended_estimate(pooled, N), "frozen linear chain of the ranking file (N > pool)"
    return None, "no a-priori estimate of this N in the ranking file"


def resolve_verified(parsed, request, scene, body_data, rankings, log=None, runs=None):
    """ModelSpec of a tol- request (a parsed name) the frozen-chain estimate cannot answer
    (``request``: the NeedsSimulation that ``resolve_tolerance`` raised: the chain does not hold
    on this scene, or the platform attitude is asked): the smallest global-N found passing by
    ``verified_search.smallest_verified``, each candidate simulated through the scene against the
    truth (``verified_search.SimulationJudge``); the frozen chain's own choice for the rates is its
    first guess.  ``spec.choice`` records the choice, the measured E (and attitude error) and every
    probe for the file's attributes.  runs: a ``verified_search.Runs`` kept by the caller across
    requests (the truth's run and each candidate's E, simulated once), or None.  ModelError
    (one line) if only the truth passes."""
    log = log or (lambda text: None)
    name, eps, att = parsed.name, parsed.eps, parsed.attitude
    invalid = isinstance(request, FrozenChainInvalid)
    pooled, available, total = _pooled_rankings(name, rankings)
    extend = (lambda n: _extended_estimate(pooled, n)) if pooled.get("path") else None
    try:
        guess = tolerance_choice(eps, pooled, total, extend=extend, check_valid=False)[0]
    except ModelError:
        guess = None                # the estimate meets eps nowhere: plain bisection

    def chain_for(N):
        spec = ModelSpec(f"global-{N}", pooled_kept(name, N, rankings, available),
                         dict.fromkeys(BODIES, ()), names.FAMILIES["global"].name)
        return build_chain(restrict_to_bodies(spec, scene.elastic_bodies), body_data, scene.damping_ratio)

    key = ("tol", scene.config_hash(), pooled.get("path_key"), tuple(scene.elastic_bodies),
           tuple(str(body_data[b]["attrs"].get("config_hash", "")) for b in BODIES))
    judge = verified_search.SimulationJudge(
        scene, chain_for, total, key=key, attitude=att is not None, runs=runs,
        log=lambda text: log(f"{name} verified search on {scene.name}: {text}"))
    limits = [eps] * 4 + ([att] if att is not None else [])
    asked = f"E <= {eps:g}" + (f" and attitude <= {att:g} arcsec" if att is not None else "")
    log(f"{name}: {request.reason}" + (f": the frozen-chain estimate is no promise on scene {scene.name!r}"
                                       if invalid else "")
        + f"; verified search over global-0..{total} for {asked} (first guess {guess})")
    t0 = time.perf_counter()
    result = verified_search.smallest_verified(limits, judge, total, guess=guess,
                                               known={total: np.zeros(len(limits))})
    wall = time.perf_counter() - t0
    if result.N >= total:
        below = [(n, e) for n, e in zip(result.probe_N, result.probe_E_max) if n < total]
        best = min(below, key=lambda p: p[1]) if below else None
        raise ModelError(f"tol-{eps:g}: on scene {scene.name!r} no pooled set smaller than the truth "
                         f"({total} modes) meets {asked} by simulation"
                         + (f" (smallest measured: global-{best[0]}, max E {best[1]:.3e})" if best else ""))
    E_est, source = apriori_estimate(pooled, result.N)
    measured = np.asarray(result.E[:4], float)
    choice = {
        "tol_eps": eps, "tol_N": int(result.N), "tol_method": TOL_VERIFIED,
        "tol_measured": measured, "tol_measured_max": float(np.max(measured)),
        "tol_estimate": np.full(4, np.nan) if E_est is None else np.asarray(E_est, float),
        "tol_estimate_max": float("nan") if E_est is None else float(np.max(E_est)),
        "tol_estimate_source": source + (" (not valid on this scene)" if invalid else ""),
        "tol_frozen_chain_valid": 0 if invalid else 1, "tol_search_reason": request.reason,
        "tol_search_N": result.probe_N, "tol_search_E_max": result.probe_E_max,
        "tol_search_probe_s": np.array([0.0 if n == total else judge.wall_time(n) for n in result.probe_N]),
        "tol_search_guess": -1 if guess is None else int(guess),
        "tol_search_integrator": verified_search.INTEGRATOR,
        "tol_search_time_s": wall, "tol_search_truth_time_s": judge.wall_time(total),
        "tol_equivalent_model": f"global-{result.N}"}
    if invalid:
        choice["tol_frozen_chain_reason"] = request.reason
    if att is not None:
        choice.update({"tol_attitude_arcsec": att,
                       "tol_measured_attitude_arcsec": float(result.E[4]),
                       "tol_search_attitude_arcsec": result.probe_attitude})
    got = f"max E {np.max(measured):.3e}" + (f", attitude {result.E[4]:.3g} arcsec" if att is not None else "")
    log(f"{name}: global-{result.N} by verified search (measured {got}, meets {asked}; global-{result.N - 1} "
        f"measured failing; {len(result.probes) - 1} simulated probes, {wall:.1f} s)" if result.N else
        f"{name}: rigid (global-0) by verified search (measured {got}, meets {asked})")
    return ModelSpec(name=name, kept=pooled_kept(name, result.N, rankings, available),
                     static=dict.fromkeys(BODIES, ()), ranking=TOL_FAMILY, choice=choice)


def frequency_rankings(body_data):
    """{body: {"rank_frequency": (D,)}}: the modes in ascending order of eigenvalue, from
    the body files (the reduction stage's rank_frequency is the same order)."""
    return {b: {RANKING_KEYS["freq"]: np.argsort(np.asarray(d["eigenvalues"]), kind="stable")}
            for b, d in body_data.items()}


def restrict_to_bodies(spec, bodies):
    """The ModelSpec with every body outside ``bodies`` rigid (no kept or static modes):
    a scene's ``needs.bodies``."""
    kept = {b: (v if b in bodies else np.zeros(0, dtype=int)) for b, v in spec.kept.items()}
    static = {b: (v if b in bodies else ()) for b, v in spec.static.items()}
    basis = {b: v for b, v in spec.basis.items() if b in bodies}
    return ModelSpec(name=spec.name, kept=kept, static=static, ranking=spec.ranking, choice=spec.choice,
                     basis=basis)


def load_load_ranking(path, rankings=None):
    """Add the load-aware rankings of ``gimbal_reduction.reduction.load_aware`` (file ``path``) to a
    rankings dict (``load_rankings``): rankings[b]["rank_load"] (D,) and
    rankings["pooled"] = {"body", "mode"} (Q,); returns it (a new dict if None)."""
    if not os.path.exists(path):
        raise FileNotFoundError(f"load-aware ranking {path} missing (run python -m "
                                f"gimbal_reduction.reduction.load_aware --scene SCENE --out {path})")
    out = {} if rankings is None else rankings
    try:
        with h5py.File(path, "r") as f:
            missing = [k for k in [f"body{b}/{LOAD_KEY}" for b in BODIES] + ["pooled/body", "pooled/mode"]
                       if k not in f]
            if missing:
                raise ModelError(f"load-aware ranking {path}: dataset(s) {', '.join(missing)} missing "
                                 f"(stale or incomplete): " + RANKING_REMEDY.format(path=path))
            for b in BODIES:
                out.setdefault(b, {})[LOAD_KEY] = f[f"body{b}/{LOAD_KEY}"][()]
            out[POOLED_KEY] = {"body": f["pooled/body"][()], "mode": f["pooled/mode"][()],
                               "scene": str(f.attrs.get("scene", "")),
                               "scene_hash": str(f.attrs.get("scene_hash", "")),
                               "scene_loads_hash": str(f.attrs.get("scene_loads_hash", "")),
                               "body_config_hashes": str(f.attrs.get("body_config_hashes", "")),
                               "path": os.path.abspath(path),
                               "path_key": (os.path.abspath(path), os.stat(path).st_mtime_ns)}
            # what tol-EPS reads: the a-priori estimates and the frozen chain's validity
            if "estimate/global" in f:
                out[POOLED_KEY]["estimate"] = f["estimate/global"][()]
            if "estimate/rigid" in f:
                out[POOLED_KEY]["rigid_estimate"] = f["estimate/rigid"][()]
            changed = content_problem(f, path, "load-aware ranking")
            for key, attr in (("angle_excursion", "angle_excursion_rad"),
                              ("rate_over_lowest_frequency", "rate_over_lowest_frequency")):
                if attr in f.attrs:
                    out[POOLED_KEY][key] = f.attrs[attr]
    except (OSError, KeyError) as exc:
        raise ModelError(f"load-aware ranking {path} unreadable or incomplete "
                         f"({exc.__class__.__name__}: {' '.join(str(exc).split())}): "
                         + RANKING_REMEDY.format(path=path)) from None
    pooled = out[POOLED_KEY]
    for key, dataset in (("estimate", "estimate/global"), ("rigid_estimate", "estimate/rigid")):
        if key in pooled:
            value = np.asarray(pooled[key])
            if value.dtype.kind not in "iuf" or not np.all(np.isfinite(value)) or np.any(value < 0):
                raise ModelError(f"load-aware ranking {path}: dataset {dataset} holds values that are not "
                                 f"finite non-negative errors (NaN, inf or negative): "
                                 + RANKING_REMEDY.format(path=path))
    for b in BODIES:
        order = np.asarray(out[b][LOAD_KEY])
        if order.ndim != 1 or not np.issubdtype(order.dtype, np.integer):
            raise ModelError(f"load-aware ranking {path}: dataset body{b}/{LOAD_KEY} is not a 1-D "
                             f"array of mode indices: " + RANKING_REMEDY.format(path=path))
    if changed:
        raise ModelError(changed)
    return out


# ------------------------------------------------------------------ body files
def load_body_file(path):
    """The FE stage's per-body file (docs/body-data.md), read and checked by its one owner
    (``gimbal_reduction.solver.bodydata.read_body_file``).  Kept in process for the next model (a study reduces
    ~50 models from the same four files, ``gimbal_reduction.results.study.run_scene``), keyed by the file's path,
    size and modification time, so a rewritten file is read again; callers treat it as read-only."""
    if not os.path.isfile(path):
        return read_body_file(path)         # raises its one-line BodyFileError
    st = os.stat(path)
    return _read_body_file(os.path.abspath(path), st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=8)
def _read_body_file(path, size, mtime_ns):
    """``read_body_file(path)`` of the file as of (size, mtime_ns), the last 8 files kept."""
    return read_body_file(path)


def load_cb_stage(path, body):
    """A ring's Craig-Bampton stage file (``bases.read_cb_stage``, checked against its body file's
    dict), kept in process for the next model as the body files are."""
    if not os.path.isfile(path):
        return bases.read_cb_stage(path, body)          # raises its one-line message
    st = os.stat(path)
    return _read_cb_stage(os.path.abspath(path), st.st_size, st.st_mtime_ns, body["path"])


@functools.lru_cache(maxsize=3)
def _read_cb_stage(path, size, mtime_ns, body_path):
    return bases.read_cb_stage(path, load_body_file(body_path))


def cb_stages_for(specs, body_data, cb_files):
    """{ring: Craig-Bampton stage dict} the ModelSpecs ``specs`` build on (their cb- bodies), read
    from cb_files {ring: path}; ModelError (one line) naming the models when they need the files
    and none are given; {} when no model is a cb- model."""
    rings = sorted({b for spec in specs for b, (family, _) in spec.basis.items() if family == names.CB})
    if rings and not cb_files:
        needing = ", ".join(repr(spec.name) for spec in specs if any(
            family == names.CB for family, _ in spec.basis.values()))
        raise ModelError(f"model(s) {needing} need the rings' Craig-Bampton stage files (--cb-bases)")
    return {b: load_cb_stage(cb_files[b], body_data[b]) for b in rings}


RANKING_REMEDY = "rerun its target: snakemake --cores 2 --forcerun {path}"


def _ranking_error(path, what):
    return ModelError(f"ranking file {path}: {what}: " + RANKING_REMEDY.format(path=path))


def read_reduction_rankings(path, body=None):
    """The rankings {rank_frequency, rank_xmx, rank_xmgmx (, rank_dominance if present)} of one
    reduction file, checked: the file exists and is HDF5, the three datasets are present, 1-D,
    of one length D, each a permutation of 0..D-1; with ``body`` (its body file's dict) D is the body's mode count and
    the file's config_hash attribute the body file's (a reduction file of another body file is
    refused).  ModelError (one line naming the file, the dataset and the target to rerun)."""
    path = str(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"ranking file {path} missing (make it: snakemake --cores 2 {path})")
    try:
        with h5py.File(path, "r") as f:
            missing = [k for k in RANKING_KEYS.values() if k not in f]
            if missing:
                raise _ranking_error(path, f"dataset(s) {', '.join(missing)} missing (stale or incomplete)")
            out = {k: f[k][()] for k in (*RANKING_KEYS.values(), *OPTIONAL_RANKING_KEYS.values()) if k in f}
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
            changed = content_problem(f, path, "ranking file")
    except ModelError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise _ranking_error(path, f"not a readable HDF5 file ({exc.__class__.__name__}; corrupt or "
                                   f"truncated)") from None
    sizes = set()
    for key, order in out.items():
        order = np.asarray(order)
        if order.ndim != 1 or not (np.issubdtype(order.dtype, np.integer) or
                                   (np.issubdtype(order.dtype, np.floating) and np.all(np.isfinite(order))
                                    and np.all(order == np.round(order)))):
            raise _ranking_error(path, f"dataset {key} is not a 1-D array of mode indices "
                                       f"(shape {order.shape}, {order.dtype})")
        order = order.astype(int)
        if np.unique(order).size != order.size or (order.size and (order.min() < 0 or
                                                                   order.max() >= order.size)):
            raise _ranking_error(path, f"dataset {key} is not a permutation of 0..{order.size - 1}")
        out[key] = order
        sizes.add(order.size)
    if len(sizes) > 1:
        raise _ranking_error(path, f"datasets {', '.join(RANKING_KEYS.values())} differ in length "
                                   f"({sorted(sizes)})")
    if body is not None:
        D = int(np.asarray(body["eigenvalues"]).size)
        if sizes and sizes.pop() != D:
            raise _ranking_error(path, f"ranks {out['rank_frequency'].size} modes, its body file "
                                       f"{body.get('path', '')} has {D} (stale)")
        mine, theirs = attrs.get("config_hash"), body["attrs"].get("config_hash")
        if mine is not None and str(mine) != str(theirs):
            raise _ranking_error(path, f"made from another body file (attribute config_hash {mine!r}, "
                                       f"body file {body.get('path', '')} has {theirs!r}; stale)")
    if changed:
        raise ModelError(changed)
    return out


def read_rankings(paths, body_data=None):
    """{body: {rank_frequency, rank_xmx, rank_xmgmx}} from the reduction files {body: path},
    each read by ``read_reduction_rankings`` (against its body file's dict in ``body_data``)."""
    return {b: read_reduction_rankings(path, None if body_data is None else body_data.get(b))
            for b, path in paths.items()}


def load_rankings(reduction_dir, bodies=BODIES):
    """{body: {rank_frequency, rank_xmx, rank_xmgmx}} from reduction_dir/body{n}.h5."""
    return read_rankings({b: os.path.join(reduction_dir, f"body{b}.h5") for b in bodies})


def static_modes_for(data, load_cases, kept_modes, kept_eigenvalues):
    """Static correction modes of one body (gimbal_reduction.reduction.static_modes, eq. 3.48) for a kept set:
    the dict of ``static_correction_modes`` (modes (ndof, s), modal_stiffness (s,), and their
    frequencies, Gram condition and couplings to the kept modes)."""
    # the factorised supported stiffness, kept with the body's data for the next model
    apply_G = data.get("_apply_G")
    if apply_G is None:
        apply_G = modal_integrals.supported_flexibility(data["K"], data["T"], data["rigid_modes"])
        data["_apply_G"] = apply_G
    F = np.column_stack([load_case_vector(data["bearing_operator"], c, data["bearing_points"])
                         for c in load_cases])
    return static_correction_modes(data["M"], data["K"], apply_G, F, kept_modes, kept_eigenvalues,
                                   names=list(load_cases))


def all_mode_integrals(data, rotate_rotation_blocks=True):
    """The modal integrals (``modal_integrals.chain_integrals``) of every mode of one body's
    file, computed once and kept in its dict (read-only, as ``_apply_G``): a study builds ~50
    models from the same four bodies, and every integral of a subset of the modes is a
    selection of these (``select_mode_integrals``)."""
    key = "_all_mode_integrals" if rotate_rotation_blocks else "_all_mode_integrals_unrotated"
    integ = data.get(key)
    if integ is None:
        integ = modal_integrals.chain_integrals(
            data["M"], np.asarray(data["modes"]), data["rigid_modes"], data["dof_coords"],
            data["dof_component"], np.asarray(data["bearing_modes"]), data["bearing_points"],
            rotate_rotation_blocks=rotate_rotation_blocks)
        data[key] = integ
    return integ


def select_mode_integrals(integ, kept):
    """The integrals of modes ``kept`` (k,) from those of all D modes: every integral is one
    column (row) per mode -- momentum (6, D), inertia_gradient (D, 6, 6), inside_translation and
    inside_rotation (3, D) -- except the Coriolis coefficients (D, 3, D), bilinear in the modes,
    whose rows and columns are both selected.  Fresh contiguous arrays."""
    kept = np.asarray(kept, dtype=int)
    out = {"rigid_mass": np.array(integ["rigid_mass"]),
           "momentum": np.ascontiguousarray(integ["momentum"][:, kept]),
           "inertia_gradient": np.ascontiguousarray(integ["inertia_gradient"][kept]),
           "coriolis": np.ascontiguousarray(integ["coriolis"][kept][:, :, kept])}
    for name in ("inside_translation", "inside_rotation"):
        if name in integ:
            out[name] = np.ascontiguousarray(integ[name][:, kept])
    return out


def basis_shapes(data, basis, cb_stage=None):
    """(shapes (ndof, n), eigenvalues (n,), labels) of a computed basis (family, N) of one body
    (``ModelSpec.basis``): ``cb`` from the ring's Craig-Bampton stage dict (``bases.read_cb_stage``),
    ``ritz`` from the body file.  Unit modal mass, diagonal stiffness."""
    family, n = basis
    if family == names.CB:
        if cb_stage is None:
            raise ModelError(f"body {data['number']}: cb-{n} needs its Craig-Bampton stage file "
                             f"(--cb-bases; make it: snakemake results/reduction/cb/body{data['number']}.h5)")
        Y, lam = bases.craig_bampton_basis(data["M"], data["K"], cb_stage["constraint_modes"],
                                           cb_stage["fixed_modes"], n)
    else:
        Y, lam = bases.ritz_basis(data, n)
    return Y, lam, [f"{family} {i}" for i in range(Y.shape[1])]


def body_from_shapes(number, data, Phi, lam, labels, damping_ratio=0.0, rotate_rotation_blocks=True,
                     bearing_modes=None):
    """multibody.Body of one body whose coordinates are the shapes Phi (ndof, n) (unit modal mass,
    M- and K-orthogonal, modal stiffness lam (n,)), whatever made them: its modal integrals
    (``modal_integrals.chain_integrals``); bearing_modes (n, 4, 6) the bearings' motion (None:
    bearing_operator @ Phi)."""
    if bearing_modes is None:
        bearing_modes = np.asarray(data["bearing_operator"] @ Phi).T.reshape(Phi.shape[1], 4, 6)
    integ = modal_integrals.chain_integrals(data["M"], Phi, data["rigid_modes"], data["dof_coords"],
                                            data["dof_component"], bearing_modes, data["bearing_points"],
                                            rotate_rotation_blocks=rotate_rotation_blocks)
    return multibody.make_body(number, integ, lam, damping_ratio, labels)


def build_body(number, data, kept, load_cases=(), damping_ratio=0.0, rotate_rotation_blocks=True,
               basis=None, cb_stage=None):
    """multibody.Body of one body: kept vibration modes plus static correction modes, or a
    computed basis (``basis`` = (family, N), ``basis_shapes``; ``cb_stage`` for cb).

    Without static modes the integrals are a selection of the body's all-mode integrals
    (``all_mode_integrals``, computed once per body); with them, computed for the kept and
    static modes together (the static modes depend on the kept set)."""
    kept = np.asarray(kept, dtype=int)
    if basis is not None:
        Phi, lam, labels = basis_shapes(data, basis, cb_stage)
        return body_from_shapes(number, data, Phi, lam, labels, damping_ratio, rotate_rotation_blocks)
    if not load_cases:
        integ = select_mode_integrals(all_mode_integrals(data, rotate_rotation_blocks), kept)
        lam = np.asarray(data["eigenvalues"])[kept]
        return multibody.make_body(number, integ, lam, damping_ratio, [f"mode {i}" for i in kept])
    Phi = np.asarray(data["modes"])[:, kept]
    lam = np.asarray(data["eigenvalues"])[kept]
    static = static_modes_for(data, load_cases, Phi, lam)
    S = static["modes"]
    bearing_modes = np.concatenate([np.asarray(data["bearing_modes"])[kept],
                                    np.asarray(data["bearing_operator"] @ S).T.reshape(S.shape[1], 4, 6)])
    return body_from_shapes(number, data, np.hstack([Phi, S]),
                            np.concatenate([lam, static["modal_stiffness"]]),
                            [f"mode {i}" for i in kept] + [f"static {c}" for c in load_cases],
                            damping_ratio, rotate_rotation_blocks, bearing_modes)


def build_chain(spec, body_data, damping_ratio=0.0, cb_stages=None):
    """multibody.Chain of a ModelSpec from {body: body-file dict} (and {ring: Craig-Bampton stage
    dict} for a cb model)."""
    cb_stages = cb_stages or {}
    bodies = tuple(build_body(b, body_data[b], spec.kept[b], spec.static[b], damping_ratio,
                              basis=spec.basis.get(b), cb_stage=cb_stages.get(b))
                   for b in BODIES)
    return multibody.Chain(bodies, name=spec.name)


# ------------------------------------------------------------------ the reduced-model file
def model_config_hash(spec, body_data, scene, ranking_hashes=()):
    """Hash of what a reduced-model file is made from: the model's kept modes and static
    load cases, the body files' config hashes, the rankings used and the scene's elastic
    bodies (16 hex digits)."""
    payload = {"model": spec.name, **({"basis": {str(b): list(v) for b, v in spec.basis.items()}}
                                      if spec.basis else {}),
               "kept": {str(b): np.asarray(v).tolist() for b, v in spec.kept.items()},
               "static": {str(b): list(v) for b, v in spec.static.items()},
               "bodies": [str(body_data[b]["attrs"].get("config_hash", "")) for b in BODIES],
               "rankings": list(ranking_hashes), "elastic_bodies": list(scene.elastic_bodies)}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]


def check_load_ranking(path, rankings, body_data, scene):
    """ModelError (one line) if a load-aware ranking was made from other body files, or for
    another scene: a ranking (and its a-priori estimates) holds for its own scene's loads only;
    the same loads under another name are accepted (the file's loads hash; a file without it is
    judged by the whole scene's hash)."""
    pooled = rankings[POOLED_KEY]
    stored = pooled.get("body_config_hashes") or ""
    current = [str(body_data[b]["attrs"].get("config_hash", "")) for b in BODIES]
    if stored and json.loads(stored) != current:
        raise ModelError(f"load-aware ranking {path} was made from other body files (config "
                         f"hashes differ): rerun python -m gimbal_reduction.reduction.load_aware")
    made_for, here = ((pooled["scene_loads_hash"], scene.loads_hash()) if pooled["scene_loads_hash"]
                      else (pooled["scene_hash"], scene.config_hash()))
    if made_for != here:
        raise ModelError(f"load-aware ranking {path} was made for scene {pooled['scene']!r} (its loads "
                         f"differ from scene {scene.name!r}'s): make it for this scene "
                         f"(gimbal load-ranking --scene {scene.name})")


def expected_body_hashes(config):
    """{body: config_hash} the current configuration gives each body file (the modal stage
    writes ``gimbal_reduction.workflow.config.inputs_hash(body_inputs(config, n))``)."""
    return {b: cfgmod.inputs_hash(cfgmod.body_inputs(config, b)) for b in BODIES}


def reduce_model(name, scene, body_files, reduction_files=None, load_ranking=None, config=None,
                 verified=True, log=None, runs=None, cb_files=None):
    """(Chain, ModelSpec, attrs) of model ``name`` on ``scene`` (undamped: damping is the
    scene's, applied when the model file is read).

    verified: answer a tol- request the frozen-chain estimate cannot (the chain does not hold on
    the scene, or the attitude is asked) by verified search (simulations; ``resolve_verified``),
    else refuse (NeedsSimulation);
    log(text): its progress lines; runs: the verified search's ``verified_search.Runs``, kept by
    a caller that answers several requests on one scene (None: a fresh one).

    body_files: {body: path} of the modal stage's files; reduction_files: {body: path} of
    the reduction stage's files (needed by xmx-, xmgmx-, dom-, load- and global- models);
    cb_files: {ring: path} of the rings' Craig-Bampton stage files (cb- models);
    load_ranking: the scene's load-aware ranking file (load- and global- models); config: the
    current configuration (validated dict): each body file's config_hash must be the one it
    gives (``expected_body_hashes``), else BodyFileError naming the file and its target."""
    check_tolerance(names.parse(name))          # before any file is read
    body_data = {b: load_body_file(body_files[b]) for b in BODIES}
    for b in BODIES:            # each file in its own slot: a body file copied over another's is refused
        if int(body_data[b]["number"]) != b:
            raise ModelError(f"{body_files[b]}: the body file of body {body_data[b]['number']} given as "
                             f"body {b}'s (the files go in the order of bodies 2, 3, 4, 5)")
    if config is not None:
        for b, expected in expected_body_hashes(config).items():
            check_config_hash(body_data[b], expected)
    parsed = names.parse(name)
    if not names.needs_load_ranking(name):
        load_ranking = None         # given but not read by this model
    if names.needs_reduction_rankings(name):
        if not reduction_files:
            raise ModelError(f"model {name!r} ranks modes by the reduction stage: pass its files "
                             f"(--reductions)")
        rankings = read_rankings(reduction_files, body_data)
    else:       # truth, rigid, freq-*, static-*: no reduction stage needed
        rankings = frequency_rankings(body_data)
    ranking_hashes = []
    if names.needs_load_ranking(name):
        if load_ranking is None:
            raise ModelError(f"model {name!r} needs the scene's load-aware ranking (--load-ranking)")
        load_load_ranking(load_ranking, rankings)
        check_load_ranking(load_ranking, rankings, body_data, scene)
        ranking_hashes.append(str(rankings[POOLED_KEY].get("body_config_hashes", "")))
    try:
        spec = model_spec(parsed, rankings)
    except NeedsSimulation as request:
        if not verified:
            raise
        spec = resolve_verified(parsed, request, scene, body_data, rankings, log, runs)
    spec = restrict_to_bodies(spec, scene.elastic_bodies)
    chain = build_chain(spec, body_data, cb_stages=cb_stages_for([spec], body_data, cb_files))
    attrs = {"model": spec.name, "scene": scene.name,
             "config_hash": model_config_hash(spec, body_data, scene, ranking_hashes),
             "n_modes": np.array(chain.n_modes), "units": "in, lbf, s",
             "body_config_hashes": json.dumps([str(body_data[b]["attrs"].get("config_hash", ""))
                                               for b in BODIES])}
    if spec.basis:
        attrs["basis"] = json.dumps({str(b): list(v) for b, v in spec.basis.items()})
    if spec.ranking == TOL_FAMILY:
        attrs.update(spec.choice)
        attrs["tol_coordinates"] = int(sum(chain.n_modes))
    if load_ranking is not None:
        attrs["load_ranking"] = os.path.abspath(load_ranking)
        attrs["load_ranking_scene"] = rankings[POOLED_KEY]["scene"]
    return chain, spec, attrs


def model_jobs(models, scenes_given, outs):
    """[(model, scene, out)] of one command line: ``--out`` names one file per model made, and
    ``--model`` and ``--scene`` each give one value (the same for every file) or one per file;
    ValueError (one line, naming the option) otherwise, or for a file named twice."""
    for option, values in (("--model", models), ("--scene", scenes_given)):
        if len(values) not in (1, len(outs)):
            raise ValueError(f"{option} gives {len(values)} values for {len(outs)} --out file(s): "
                             f"give one, or one per --out file")
    twice = sorted({o for o in outs if outs.count(o) > 1})
    if twice:
        raise ValueError(f"--out names {', '.join(twice)} more than once")
    models = models * len(outs) if len(models) == 1 else models
    scenes_given = scenes_given * len(outs) if len(scenes_given) == 1 else scenes_given
    return list(zip(models, scenes_given, outs))


def main(argv=None, runs=None):
    """The stage's command line; runs: the verified search's ``verified_search.Runs`` of a caller
    that runs several stages in process (None: a fresh one).  Several models in one call
    (``model_jobs``) share one process: the interpreter, the imports and the body files are
    paid once (a workflow job costs ~2 s before its first model; most models take 0.02-0.3 s)."""
    ap = cli.OneLineParser(prog="gimbal_reduction.reduction.models",
                           description="Reduce the chain to one model on one scene: the reduced-model "
                                       "file (gimbal_reduction/solver/dynamics/chainfile.py, docs/models.md) a "
                                       "simulation reads.")
    ap.add_argument("--model", required=True, nargs="+",
                    help="model name (grammar: gimbal_reduction/reduction/models.py); one, or one per --out")
    ap.add_argument("--scene", required=True, nargs="+",
                    help="scene file (config/scenes/NAME.yaml) or name; one, or one per --out")
    ap.add_argument("--bodies", nargs=4, required=True, metavar="BODY_FILE",
                    help="the modal stage's files of bodies 2, 3, 4, 5")
    ap.add_argument("--reductions", nargs=4, metavar="REDUCTION_FILE",
                    help="the reduction stage's files of bodies 2..5 (xmx-, xmgmx-, load-, global-)")
    ap.add_argument("--load-ranking", help="the scene's load-aware ranking (load-, global-)")
    ap.add_argument("--cb-bases", nargs=3, metavar="CB_FILE",
                    help="the Craig-Bampton stage files of rings 2, 3, 4 (cb-)")
    cli.add_config_option(ap, "every body file's config_hash must be the one it gives")
    ap.add_argument("--out", required=True, nargs="+",
                    help="reduced-model file(s) to write (.h5), one per model made")
    ap.add_argument("--no-verified-search", action="store_true",
                    help="tol-EPS where the frozen-chain estimate does not hold: refuse, instead of "
                         "simulating candidates against the truth (minutes on the long scene)")
    try:
        args = ap.parse_args(cli.values_joined(sys.argv[1:] if argv is None else argv, ap))
    except SystemExit as exc:       # the one-line message is printed; in process, return the status
        return exc.code
    try:
        jobs = model_jobs(args.model, args.scene, args.out)
        # every name, scene and output checked before the first model is made
        for model, _, out in jobs:
            check_tolerance(names.parse(model))
            cli.check_writable(out)
        scene_of = {name: scenes.load_scene(name) for name in dict.fromkeys(s for _, s, _ in jobs)}
        config = cfgmod.load_config(args.config) if args.config else None
        # the body files' attributes first (the configuration file named in the remedy), then their data
        bodyconfig.check_slots(args.bodies)
        bodyconfig.check_slots(args.reductions or [])
        bodyconfig.check_files(args.bodies, args.config)
    except (ValueError, FileNotFoundError) as exc:
        print(f"gimbal_reduction.reduction.models: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    made = []           # every model reduced before the first file is written: a bad one writes nothing
    for model, scene_name, out in jobs:
        t0 = time.perf_counter()
        try:
            chain, spec, attrs = reduce_model(
                model, scene_of[scene_name], dict(zip(BODIES, args.bodies)),
                dict(zip(BODIES, args.reductions)) if args.reductions else None, args.load_ranking,
                config=config, verified=not args.no_verified_search, runs=runs,
                cb_files=dict(zip(names.INTERFACE_BODIES, args.cb_bases)) if args.cb_bases else None,
                log=lambda text: print(f"gimbal_reduction.reduction.models: {text}", file=sys.stderr, flush=True))
        except (ValueError, FileNotFoundError) as exc:
            print(f"gimbal_reduction.reduction.models: {' '.join(str(exc).split())}", file=sys.stderr)
            return 2
        attrs["wall_time_s"] = time.perf_counter() - t0
        made.append((out, chain, spec, attrs))
    for out, chain, spec, attrs in made:
        rc = write_model(out, chain, spec, attrs)
        if rc:
            return rc
    return 0


def write_model(out, chain, spec, attrs):
    """Write one reduced model of ``main`` (its file and its line on stdout); the exit status (2
    with a one-line message on stderr if the file cannot be written)."""
    attrs.update({f"version_{k}": str(v) for k, v in versions().items()})
    attrs["created"] = time.strftime("%Y-%m-%dT%H:%M:%S")
    try:
        chainfile.write_chain(out, chain, spec.kept, spec.static, attrs)
    except OSError as exc:
        print(f"gimbal_reduction.reduction.models: {cli.write_failure(out, exc)}", file=sys.stderr)
        return 2
    if attrs.get("tol_method") == TOL_APRIORI:
        print(f"gimbal_reduction.reduction.models: {spec.name}: global-{attrs['tol_N']} (a-priori max E "
              f"{attrs['tol_estimate_max']:.3e} <= {attrs['tol_eps']:g}; {attrs['tol_estimate_source']})")
    elif attrs.get("tol_method") == TOL_VERIFIED:
        print(f"gimbal_reduction.reduction.models: {spec.name}: global-{attrs['tol_N']} by verified search (measured "
              f"max E {attrs['tol_measured_max']:.3e} <= {attrs['tol_eps']:g}"
              + (f", attitude {attrs['tol_measured_attitude_arcsec']:.3g} <= {attrs['tol_attitude_arcsec']:g} "
                 f"arcsec" if "tol_attitude_arcsec" in attrs else "")
              + f"; {attrs['tol_search_reason']}; the frozen chain estimated {attrs['tol_estimate_max']:.3e})")
    print(f"gimbal_reduction.reduction.models: {out}: model {spec.name} on scene {attrs['scene']}, "
          f"{sum(chain.n_modes)} elastic coordinates {chain.n_modes} in {attrs['wall_time_s']:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Which modes a model name keeps: the selection from the rankings, checked against the computed
modes, with NumPy and the name grammar only (``gimbal_reduction.reduction.names``).

``check_name`` is what the workflow asks of every model name while it builds the DAG (the
rankings taken as the identity: grammar, counts, load cases), so this module imports no
reader, solver or compiled kernel; ``gimbal_reduction.reduction.models`` builds the models
from it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gimbal_reduction.reduction import names
from gimbal_reduction.reduction.names import TRUTH_MODES, ModelError
from gimbal_reduction.solver.bodies import BODIES

# the reduction stage's datasets, one per ranking it writes (results/reduction/body{n}.h5)
RANKING_KEYS = {f: names.FAMILIES[f].ranking for f in ("freq", "xmx", "xmgmx")}
# read where present (a dom- model without it is refused by select_modes): files of the stage
# before the dominance ranking still serve every other family
OPTIONAL_RANKING_KEYS = {f: names.FAMILIES[f].ranking for f in ("dom",)}
LOAD_KEY = names.FAMILIES["load"].ranking            # per-body load-aware ranking
POOLED_KEY = names.FAMILIES["global"].ranking        # pooled ranking: rankings["pooled"]
TOL_FAMILY = names.TOL                               # tol-EPS: smallest global-N with estimate <= EPS
# [1] E of eq. 3.53: the smallest EPS a tol- request may ask.  The truth a request is judged
# against is itself only this close to the converged reference: its integration at the workflow's
# tolerance holds E <= 1e-8 against DOP853 at rtol 1e-10 on every verified scene (the scene's own
# exponential_tolerance where it states one; docs/exponential.md Section 5: 4.4e-9 on long, 7.5e-9
# on thesis).  Below it the search would judge the integrators' round-off, whose outcome depends
# on the order of floating-point sums (the BLAS thread count), not the model.
TOL_FLOOR = 1e-8


@dataclass(frozen=True)
class ModelSpec:
    """What a model name means: kept vibration mode indices and static load cases per body;
    ``choice``: for a tol- request, how its N was chosen (the reduced-model file's ``tol_*``
    attributes), else empty; ``basis``: {body: (family, N)} of the bodies whose coordinates are a
    computed basis (cb, ritz: ``bases``) instead of kept modes (their ``kept`` is empty)."""
    name: str
    kept: dict          # body -> int array (0-based indices into the body file's modes)
    static: dict        # body -> tuple of load case names
    ranking: str
    choice: dict = field(default_factory=dict)
    basis: dict = field(default_factory=dict)

    def n_modes(self, body):
        family, n = self.basis.get(body, ("", 0))
        extra = n + (names.INTERFACE_DOFS if family == names.CB else 0)
        return len(self.kept[body]) + len(self.static[body]) + extra


def _available(name, rankings):
    """{body: computed modes D} from the frequency rankings; ModelError if a body has none."""
    available = {}
    for b in BODIES:
        if b not in rankings:
            raise ModelError(f"model {name!r}: no ranking data for body {b}")
        available[b] = len(np.asarray(rankings[b]["rank_frequency"]))
    return available


def select_modes(parsed, rankings):
    """ModelSpec of a parsed name of a mode family (truth, rigid, FAMILY-counts, pooled-N): the
    first modes of its ranking, checked against the computed modes."""
    name = parsed.name
    available = _available(name, rankings)
    family = names.FAMILIES[parsed.ranking]
    if family.pooled:
        kept = pooled_kept(name, parsed.total, rankings, available)
        return ModelSpec(name=name, kept=kept, static=parsed.load_cases, ranking=family.name)
    key = family.ranking
    if any(key not in rankings[b] for b in BODIES):
        if family.load_ranking:
            raise ModelError(f"model {name!r}: no load-aware ranking loaded (python -m "
                             f"gimbal_reduction.reduction.load_aware; simulate --load-ranking PATH)")
        raise ModelError(f"model {name!r}: no {key} ranking loaded (the reduction stage's files)")
    kept = {}
    for b in BODIES:
        count = parsed.counts[b]
        if count > available[b]:
            raise ModelError(f"model {name!r}: body {b} asks for {count} modes, only "
                             f"{available[b]} computed")
        order = np.asarray(rankings[b][key], dtype=int)
        if order.size != available[b] or np.unique(order).size != order.size or \
                (order.size and (order.min() < 0 or order.max() >= available[b])):
            raise ModelError(f"model {name!r}: ranking {key} of body {b} is not "
                             f"a permutation of 0..{available[b] - 1}")
        kept[b] = np.sort(order[:count])
    basis = {}
    if family.basis:     # a computed basis in place of the modes (cb: on the rings only)
        for b in BODIES:
            if family.basis == names.RITZ or b in names.INTERFACE_BODIES:
                basis[b] = (family.basis, int(parsed.counts[b]))
                kept[b] = np.zeros(0, dtype=int)
    return ModelSpec(name=name, kept=kept, static=parsed.load_cases, ranking=parsed.ranking,
                     basis=basis)


def identity_rankings(n_modes):
    """Rankings of body files of ``n_modes`` modes each in which every ranking (per body, pooled)
    is the identity: what the grammar and the counts are checked against when the order does
    not matter (``check_name``)."""
    order = np.arange(int(n_modes))
    rankings = {b: {key: order for key in (*RANKING_KEYS.values(), *OPTIONAL_RANKING_KEYS.values(), LOAD_KEY)}
                for b in BODIES}
    rankings[POOLED_KEY] = {"body": np.repeat(BODIES, order.size), "mode": np.tile(order, len(BODIES))}
    return rankings


def check_name(name, n_modes=TRUTH_MODES):
    """Refuse (ModelError, one line) a model name that cannot be built from body files of
    ``n_modes`` modes each, from the name alone: its grammar, its counts, its load cases (the
    rankings' order does not matter here, so every ranking is taken as the identity).  The
    workflow calls it when the DAG is built (workflow/rules/common.smk), before any mesh or
    modal solve; a tol-EPS name is checked for its EPS (its N is chosen from the rankings)."""
    parsed = names.parse(name)
    if parsed.family != TOL_FAMILY:
        select_modes(parsed, identity_rankings(n_modes))
    check_tolerance(parsed)


def check_tolerance(parsed):
    """ModelError (one line) for a tol-EPS request below ``TOL_FLOOR``, the truth's own error: no
    model can be shown to meet it.  Judged from the name alone, before any file is read."""
    if parsed.family == TOL_FAMILY and parsed.eps < TOL_FLOOR:
        raise ModelError(f"model {parsed.name!r}: EPS {parsed.eps:g} is below {TOL_FLOOR:g}, the truth's own "
                         f"error against the converged reference (its integration on every verified "
                         f"scene, docs/exponential.md Section 5): no model can be shown to meet it; ask "
                         f"tol-{TOL_FLOOR:g} or more")


def pooled_kept(name, n, rankings, available):
    """Kept modes per body of ``global-N``: the first N entries of the pooled ranking
    rankings["pooled"] = {"body": (Q,), "mode": (Q,)} (body 2..5, 0-based mode)."""
    n = int(n)
    pooled = rankings.get(POOLED_KEY)
    if pooled is None:
        raise ModelError(f"model {name!r}: no pooled load-aware ranking loaded (python -m "
                         f"gimbal_reduction.reduction.load_aware; simulate --load-ranking PATH)")
    body = np.asarray(pooled["body"], dtype=int)
    mode = np.asarray(pooled["mode"], dtype=int)
    total = sum(available.values())
    pairs = set(zip(body.tolist(), mode.tolist()))
    if body.shape != mode.shape or body.size != total or len(pairs) != total or \
            any(b not in available or not 0 <= i < available[b] for b, i in pairs):
        raise ModelError(f"model {name!r}: the pooled ranking is not a permutation of the "
                         f"{total} computed modes of bodies 2..5")
    if n > total:
        raise ModelError(f"model {name!r}: asks for {n} modes in total, only {total} computed")
    return {b: np.sort(mode[:n][body[:n] == b]) for b in BODIES}

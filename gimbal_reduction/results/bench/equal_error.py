"""The cheapest study model of a selection family that meets an error request (pure).

For a requested tolerance EPS and a family (``freq``: the lowest N modes of every body,
``xmx``: XMX-ranked, ``global``: the pooled load-aware ranking's first N), the answer is the
family's model in a scene's study error table (``results/tables/{scene}/errors_ranking.csv``,
``gimbal_reduction.results.study.tables``) with the fewest elastic coordinates whose measured error meets EPS on
every gimbal rate:

    max_n E_n <= EPS,   E_n of eq. 3.53, n = the four gimbal rates,

ties broken by the smaller max E.  ``tol-EPS`` answers the same request by construction, so the
two are compared at equal error: both meet EPS on the scene.  Read by ``gimbal_reduction.results.bench.tolerance``
(which times these models beside tol-EPS in one run) and ``gimbal_reduction.results.study.study_report`` (the
chart "cost against requested tolerance").  Only the study's own models are candidates (freq-,
xmx-N with N = 5..25 per body, global-N with N = 20..100 in total): where none meets EPS the
answer is None, which says the study's sizes do not reach it, not that the family cannot.
"""
from __future__ import annotations

import math

from gimbal_reduction.reduction import names
from gimbal_reduction.results.study.tables import RATE_COLUMNS

FAMILIES = ("freq", "xmx", "global")


def max_error(row) -> float:
    """Largest E of a table row over the four gimbal rates (inf if any is missing or not finite)."""
    values = [row.get(c) for c in RATE_COLUMNS]
    if any(v is None or v == "" for v in values):
        return math.inf
    values = [float(v) for v in values]
    return max(values) if all(math.isfinite(v) for v in values) else math.inf


def family_of(model) -> str | None:
    """``freq``, ``xmx`` or ``global`` for a model named FAMILY-N (one count, no static modes);
    None for any other model (rigid, truth, per-body counts, static-*, ...)."""
    parsed = names.parse_or_none(model)
    plain = None if parsed is None else parsed.plain
    return plain[0] if plain is not None and plain[0] in FAMILIES else None


def cheapest_within(rows, family, eps) -> dict | None:
    """The table row of ``family`` with the fewest elastic coordinates (``n_elastic``) whose max
    E <= eps (ties: smaller E); None if no row of the family meets eps."""
    ok = [r for r in rows if family_of(r.get("model")) == family and r.get("n_elastic") not in (None, "")
          and max_error(r) <= eps]
    if not ok:
        return None
    return min(ok, key=lambda r: (int(r["n_elastic"]), max_error(r)))


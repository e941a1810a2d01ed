"""Model names: the one owner of their grammar, their families and how they are drawn.

Grammar (bodies are 2, 3, 4, 5 = outer, middle, inner gimbal, platform)::

    model   := "truth" | "rigid" | family "-" counts statics | pooled "-" N statics
             | "tol-" EPS [ "-att-" A ]   EPS, A positive numbers, e.g. tol-1e-4, tol-1e-4-att-2
    family  := "freq" | "xmx" | "xmgmx" | "dom" | "load"      vibration modes only
             | "static" | "static-freq" | "static-xmx" | "static-xmgmx" | "static-dom" | "static-load"
             | "cb" | "ritz"          a computed basis per body, no static modes (``basis``)
    pooled  := "global" | "static-global"     N modes in total, pooled over the bodies
    counts  := N | N,N,N,N        kept vibration modes, all bodies or per body 2..5
    statics := ( "@" body ":" loadcase ( "+" loadcase )* )*
    loadcase:= {input_motor|input_resolver|output_motor|output_resolver}_{f|m}{x|y|z}

What the names mean (which modes each family keeps, what a ``tol-`` request resolves to) is
``gimbal_reduction.reduction.models``'s; this module only reads names:

* ``parse(name)`` -> ``ModelName``: the typed value of a name (family, per-body counts or the
  pooled N, the static load cases per body, the tol- request), a pure function of the string;
  a malformed name raises ModelError with a one-line message.
* ``FAMILIES``: the mode families, one row each: the rankings entry their order comes from,
  whether N is per body or pooled, which stage files they read, and for ``cb`` / ``ritz`` the
  basis computed in place of selected modes (``gimbal_reduction.reduction.bases``).  A new family
  is a row here and the code that builds its basis in ``models``.
* ``ModelName.family``, ``.group``, ``.count``, ``.plain``, ``.n_coordinates``: the family, the
  display group, the count, the (family, N) of a plain family-N name, the kept elastic
  coordinates implied by the name.
* ``STYLES`` / ``style(group)``: label, colour, marker and line style of every display group
  (the study's groups included), the one table every figure and report reads.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

from gimbal_reduction.solver.bodies import BEARING_NAMES, BODIES

TRUTH, RIGID, TOL = "truth", "rigid", "tol"
TRUTH_MODES = 100           # the truth: the 100 lowest-frequency modes of every body
STATIC_PREFIX = "static-"
# The static correction mode a "static-" name puts on every body: output_motor_fz on bodies 2-4
# (the thesis's Figure 4-12); input_motor_fx on the platform, which has no output bearings
DEFAULT_LOAD_CASE = {2: "output_motor_fz", 3: "output_motor_fz", 4: "output_motor_fz",
                     5: "input_motor_fx"}


class ModelError(ValueError):
    """A model name that cannot be built."""


@dataclass(frozen=True)
class Family:
    """One mode family of the grammar: ``ranking``, the key of the rankings dict its order is
    read from (per body, or the pooled ranking); ``pooled``: N counts the modes of all bodies
    together; ``reduction_stage`` / ``load_ranking``: it reads the reduction stage's files / the
    scene's load-aware ranking file; ``basis``: the body's coordinates are a basis computed from
    its file (``cb``: Craig-Bampton, N fixed-interface modes + the INTERFACE_DOFS constraint modes
    of a ring, from the ring's Craig-Bampton stage file; the platform keeps its N lowest modes;
    ``ritz``: N load-dependent Ritz vectors), "" for a selection of the body's modes."""
    name: str
    ranking: str
    pooled: bool = False
    reduction_stage: bool = False
    load_ranking: bool = False
    basis: str = ""


FAMILIES = {f.name: f for f in (
    Family("freq", "rank_frequency"),
    Family("xmx", "rank_xmx", reduction_stage=True),
    Family("xmgmx", "rank_xmgmx", reduction_stage=True),
    Family("dom", "rank_dominance", reduction_stage=True),
    Family("load", "rank_load", reduction_stage=True, load_ranking=True),
    Family("global", "pooled", pooled=True, reduction_stage=True, load_ranking=True),
    Family("cb", "rank_frequency", basis="cb"),
    Family("ritz", "rank_frequency", basis="ritz"),
)}
CB, RITZ = "cb", "ritz"
# Craig-Bampton: the output interface's DOFs of a ring (one constraint mode each), the rings that
# have one, and the fixed-interface modes its stage file holds (as many as the truth's modes)
INTERFACE_DOFS = 6
INTERFACE_BODIES = (2, 3, 4)
CB_FIXED_MODES = TRUTH_MODES
DEFAULT_FAMILY = "freq"     # "static-N", "truth" and "rigid" keep the lowest-frequency modes

_NUMBER = r"((?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
_TOL = re.compile(rf"tol-{_NUMBER}(?:-att-{_NUMBER})?")     # tol-EPS, tol-EPS-att-ARCSEC
_MODES = re.compile(rf"({STATIC_PREFIX})?(?:({'|'.join(FAMILIES)})-)?([0-9,]+)")
_COUNT = re.compile(r"\d+")
_BODY = re.compile(r"[2-5]")
_LOAD_CASE = re.compile(rf"^({'|'.join(BEARING_NAMES)})_[fm][xyz]$")


@dataclass(frozen=True)
class ModelName:
    """A parsed model name.

    family: ``truth``, ``rigid``, ``tol`` or a key of FAMILIES; counts: kept vibration modes per
    body {body: N} (per-body families, truth, rigid); total: N of a pooled family; static: the
    "static-" prefix (the default load case on every body unless ``statics`` lists them);
    statics: the @body:case list {body: (case, ...)}; eps, attitude: the tol- request (attitude
    None if not asked)."""
    name: str
    family: str
    counts: dict | None = None
    total: int | None = None
    static: bool = False
    statics: dict | None = None
    eps: float | None = None
    attitude: float | None = None

    @property
    def ranking(self):
        """The family whose ranking selects the modes (truth and rigid: by frequency)."""
        return DEFAULT_FAMILY if self.family in (TRUTH, RIGID) else self.family

    @property
    def load_cases(self):
        """Static load cases per body {body: (case, ...)}: the @body:case list, the default case
        of every body ("static-"), or none."""
        if self.statics:
            return {b: self.statics.get(b, ()) for b in BODIES}
        if self.static:
            return {b: (DEFAULT_LOAD_CASE[b],) for b in BODIES}
        return dict.fromkeys(BODIES, ())

    @property
    def count(self):
        """N: the count of every body (per-body families, None if the bodies differ) or the
        pooled total; None for a tol- request."""
        if self.total is not None:
            return self.total
        if self.counts is None or len(set(self.counts.values())) != 1:
            return None
        return next(iter(self.counts.values()))

    @property
    def plain(self):
        """(family, N) of a FAMILY-N name with vibration modes only, one count (per body, or in
        total); None for every other name (truth, rigid, tol-, static modes, per-body counts)."""
        if self.family not in FAMILIES or self.static or self.statics or self.count is None:
            return None
        return self.family, self.count

    @property
    def group(self):
        """Display group (a key of STYLES): truth, rigid, tol, the family, "static-" + family with
        the default static modes; ``other`` for per-body counts or an @body:case list."""
        if self.family in (TRUTH, RIGID, TOL):
            return self.family
        if self.statics or self.count is None:
            return "other"
        return STATIC_PREFIX + self.family if self.static else self.family

    @property
    def n_coordinates(self):
        """Kept elastic coordinates over the four bodies implied by the name (vibration plus
        static modes; every body elastic); None for a tol- request (its N is chosen)."""
        if self.family == TOL:
            return None
        statics = sum(len(c) for c in self.load_cases.values())
        constraint = INTERFACE_DOFS * len(INTERFACE_BODIES) if self.family == CB else 0
        return (self.total if self.total is not None else sum(self.counts.values())) + statics + constraint


def _counts(text, name):
    parts = text.split(",")
    if len(parts) not in (1, 4) or not all(_COUNT.fullmatch(p) for p in parts):
        raise ModelError(f"model {name!r}: counts must be N or N,N,N,N (bodies 2..5), got {text!r}")
    vals = [int(p) for p in parts]
    return dict(zip(BODIES, vals * 4 if len(vals) == 1 else vals))


def _statics(text, name):
    out = {}
    for chunk in text.split("@")[1:]:
        body_s, sep, cases = chunk.partition(":")
        if not sep or not _BODY.fullmatch(body_s):
            raise ModelError(f"model {name!r}: static spec must be @body:loadcase with body 2..5, "
                             f"got '@{chunk}'")
        body = int(body_s)
        if body in out:
            raise ModelError(f"model {name!r}: body {body} given twice")
        names = tuple(cases.split("+"))
        for c in names:
            if not _LOAD_CASE.match(c):
                raise ModelError(f"model {name!r}: unknown load case {c!r} (expected "
                                 f"{{bearing}}_{{f|m}}{{x|y|z}}, bearing in {', '.join(BEARING_NAMES)})")
        if len(set(names)) != len(names):
            raise ModelError(f"model {name!r}: repeated load case on body {body}")
        if body == 5 and any(c.startswith("output") for c in names):
            raise ModelError(f"model {name!r}: the platform (body 5) has no output bearings")
        out[body] = names
    return out


def _request(name, base):
    """ModelName of a tol- name (``base``: the name before any "@")."""
    m = _TOL.fullmatch(base)
    if "@" in name:
        raise ModelError(f"model {name!r}: tol-EPS takes no static modes (@body:case)")
    if not m:
        raise ModelError(f"model {name!r}: tol-EPS needs a positive number EPS, e.g. tol-1e-4 "
                         f"(or tol-1e-4-att-2: also the platform attitude within 2 arcsec)")
    eps, att = float(m.group(1)), None if m.group(2) is None else float(m.group(2))
    for what, value in (("tolerance", eps), ("attitude tolerance", att)):
        if value is not None and (not math.isfinite(value) or value <= 0):
            raise ModelError(f"model {name!r}: the {what} must be positive and finite, got {value}")
    return ModelName(name=name, family=TOL, eps=eps, attitude=att)


def parse(name) -> ModelName:
    """The ModelName of a model name (module docstring); ModelError (one line) if malformed.
    Counts are not checked against the computed modes here (``models.model_spec`` does)."""
    if not isinstance(name, str) or not name:
        raise ModelError(f"model name must be a non-empty string, got {name!r}")
    base = name.partition("@")[0]
    if base.startswith(TOL + "-"):
        return _request(name, base)
    statics = _statics(name, name) if "@" in name else {}
    if base in (TRUTH, RIGID):
        if statics:
            raise ModelError(f"model {name!r}: '{base}' takes no static modes")
        return ModelName(name=name, family=base,
                         counts=dict.fromkeys(BODIES, TRUTH_MODES if base == TRUTH else 0), statics={})
    m = _MODES.fullmatch(base)
    if not m or (m.group(1) is None and m.group(2) is None):
        raise ModelError(
            f"unknown model {name!r}: expected truth, rigid, freq-N, xmx-N, xmgmx-N, dom-N, load-N, "
            f"global-N, cb-N, ritz-N, static-N, static-xmx-N, static-xmgmx-N, static-dom-N, static-load-N "
            f"(N or N,N,N,N; global-N: one total N; optional @body:loadcase) or tol-EPS")
    family = m.group(2) or DEFAULT_FAMILY
    static = m.group(1) is not None
    if FAMILIES[family].basis and (static or statics):
        raise ModelError(f"model {name!r}: {family}-N is a computed basis and takes no static modes "
                         f"(its own load vectors are in it)")
    if FAMILIES[family].pooled:
        if not _COUNT.fullmatch(m.group(3)):
            raise ModelError(f"model {name!r}: {family}-N takes one total count N (modes over all "
                             f"bodies), got {m.group(3)!r}")
        return ModelName(name=name, family=family, total=int(m.group(3)), static=static, statics=statics)
    return ModelName(name=name, family=family, counts=_counts(m.group(3), name), static=static,
                     statics=statics)


def parse_or_none(name) -> ModelName | None:
    """``parse(name)``, or None if the name is malformed (for labelling, not for building)."""
    try:
        return parse(str(name))
    except ModelError:
        return None


def request(name):
    """(EPS, A) of a ``tol-EPS`` or ``tol-EPS-att-A`` name: E <= EPS on every gimbal rate, and
    the platform's attitude error <= A arcsec (None: not asked); None if the name is not a tol-
    name; ModelError (one line) for a malformed one."""
    if not str(name).partition("@")[0].startswith(TOL + "-"):
        return None
    parsed = parse(str(name))
    return parsed.eps, parsed.attitude


def needs_reduction_rankings(name):
    """True if the model's mode selection reads the reduction stage's rankings: xmx-*,
    xmgmx-*, and load-* / global-* (whose ranking file is checked against them), tol-*.  truth,
    rigid, freq-* and static(-freq)-* select by frequency from the body files alone, so their
    simulations do not wait for the reduction stage.  False for a malformed name."""
    parsed = parse_or_none(name)
    return parsed is not None and (parsed.family == TOL or (
        parsed.family in FAMILIES and FAMILIES[parsed.family].reduction_stage))


def needs_basis_stage(name):
    """True if the model needs the rings' Craig-Bampton stage files (cb-*): the fixed-interface
    modes, one more modal solve per ring, made only for the models that use them.  False for a
    malformed name."""
    parsed = parse_or_none(name)
    return parsed is not None and parsed.family == CB


def needs_load_ranking(name):
    """True if the model name uses the scene's load-aware ranking (load-*, global-*, tol-*);
    False for a malformed name."""
    parsed = parse_or_none(name)
    return parsed is not None and (parsed.family == TOL or (
        parsed.family in FAMILIES and FAMILIES[parsed.family].load_ranking))


# ------------------------------------------------------------------ how a name is drawn
@dataclass(frozen=True)
class Style:
    """How a display group is shown: ``label`` in legends and tables, matplotlib ``colour``,
    ``marker`` and ``line`` style ("" = points only)."""
    label: str
    colour: str
    marker: str
    line: str


STYLES = {
    "freq": Style("lowest-frequency modes", "tab:blue", "o", "-"),
    "xmx": Style("XMX-ranked modes", "tab:orange", "s", "-"),
    "xmgmx": Style("XMGMX-ranked modes", "tab:green", "^", "--"),
    "static-freq": Style("1 static + lowest-frequency modes", "tab:purple", "D", "-"),
    "static-xmx": Style("1 static + XMX-ranked modes", "tab:red", "v", "-"),
    "static-xmgmx": Style("1 static + XMGMX-ranked modes", "tab:brown", "P", "--"),
    "load-case": Style("10 lowest modes + 1 static mode on the outer gimbal", "tab:pink", "X", ""),
    "rigid": Style("rigid bodies (no elastic mode)", "black", "_", "--"),
    "load": Style("modes ranked by the scene's joint loads", "tab:olive", "h", "-"),
    "global": Style("modes pooled over the bodies (total count)", "tab:cyan", "p", "-"),
    "dom": Style("dominance-ranked modes", "teal", "d", ":"),
    "cb": Style("Craig-Bampton (N fixed-interface + 6 constraint modes)", "darkred", "<", "-."),
    "ritz": Style("load-dependent Ritz vectors", "darkblue", ">", "-."),
    "cb-equal": Style("Craig-Bampton at equal coordinates", "salmon", "<", ":"),
    "truth-interface": Style("Craig-Bampton, 100 fixed-interface modes (interface flexibility)", "0.6",
                             "P", ""),
    "truth-check": Style("truth + 1 static mode per body (residual flexibility)", "0.4", "*", ""),
    "truth": Style("truth model (100 modes per body)", "black", "*", ""),
    "other": Style("other model", "tab:gray", ".", ""),
}


def style(group) -> Style:
    """The Style of a display group (``other``'s for a group not in STYLES)."""
    return STYLES.get(group, STYLES["other"])


def label(group) -> str:
    """The legend label of a display group (the group itself if it has no row in STYLES)."""
    return STYLES[group].label if group in STYLES else str(group)

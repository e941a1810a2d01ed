"""The thesis study (Balucan 2001, Sections 4.3-4.4) as a list of reduced-model names.

Every case is a model name of the grammar of ``gimbal_reduction.reduction.models`` (``freq-10``,
``xmx-5``, ``static-xmgmx-4``, ``static-10@2:output_motor_my`` ...), so a
Snakefile can expand ``results/sim/{scene}/{model}.h5`` over
``study.study_models()``.  Groups (``group`` field of ``study_cases``):

============  ============================================  ====================
group         cases                                         thesis
============  ============================================  ====================
freq          5, 10, 15, 20, 25 lowest modes per body       Figs 4-2..4-6, Tab 4.2
xmx, xmgmx    5..25 XMX / XMGMX-ranked modes per body       Figs 4-7..4-11, Tab 4.2
static-freq   1 static + 2, 4, 6, 8 lowest modes per body   Figs 4-13..4-16, Tab 4.3
static-xmx,   1 static + 2, 4, 6, 8 ranked modes per body   Figs 4-17..4-20, Tab 4.3
static-xmgmx
load-case     10 lowest modes per body + 1 static mode on   Figs 4-21..4-27
              the outer gimbal, one of 7 load cases
rigid         no elastic mode (the baseline every case must   (not in the thesis)
              beat to be worth its coordinates)
freq          2, 4, 6, 8 lowest modes: the no-static          (controls)
              controls of static-2..8
load          5..25 modes per body ranked by the scene's      (not in the thesis;
              joint loads (docs/selection.md)                 its Section 5.1 advice)
global        20..100 modes in total pooled over the bodies   (as load)
dom           5..25 dominance-ranked modes per body           (the field's defaults:
cb            Craig-Bampton: 5..25 fixed-interface modes +    pyMOR, Adams, Simpack,
              6 constraint modes per ring, lowest modes on    Abaqus, Wilson et al.;
              the platform                                    docs/selection.md)
ritz          5..25 load-dependent Ritz vectors per body
cb-equal      Craig-Bampton with as many elastic coordinates  (the control of the
              as freq-N (N = 10..25) and static-6, static-8:  thesis's selections
              cb-(N-6),(N-6),(N-6),N                          against it)
truth-check   the truth + 1 static mode per body (residual    (the truth's own
              flexibility of the truncated modes)             error)
truth-        cb-100: Craig-Bampton with all 100 fixed-       (the truth's own
interface     interface modes, i.e. the truth's band plus     error at the
              the interface's static flexibility               interfaces)
============  ============================================  ====================

The thesis ranks with one criterion for both XMX and XMGMX (its first 40
ranked modes coincide); ours differ (docs/reduction.md, "Finding 2 on our
model"), so both rankings are run wherever the thesis used "ranked" modes.

Pure functions, no file read; the workflow reads them while it builds the DAG, so this module
imports only the name grammar (``names``, ``selection``), not the readers or the solvers.
"""
from __future__ import annotations

import argparse

from gimbal_reduction.reduction import names, selection
from gimbal_reduction.solver.bodies import BODIES
from gimbal_reduction.workflow import config

BODY_NAMES = dict(zip(BODIES, config.BODY_NAMES))   # {2: "outer_gimbal", ..., 5: "stable_platform"}
BODY_LABELS = {2: "outer gimbal", 3: "middle gimbal", 4: "inner gimbal", 5: "stable platform"}
RATE_LABELS = {2: r"$\dot\gamma_1$ (outer gimbal)", 3: r"$\dot\gamma_2$ (middle gimbal)",
               4: r"$\dot\gamma_3$ (inner gimbal)", 5: r"$\dot\gamma_4$ (stable platform)"}
TRUTH = "truth"
TRUTH_CHECK = "static-100"      # the truth + residual flexibility: the truth's own error, not a case
# the truth against a basis that also holds the static flexibility of the six DOFs through which
# each ring carries the next body (its 6 constraint modes): the truth's error there, not a case
TRUTH_INTERFACE = f"cb-{names.TRUTH_MODES}"
REFEREES = ("truth-check", "truth-interface")       # groups that judge the truth, not cases
# The scenes of the study (config/scenes/NAME.yaml), each with every case: the thesis's scene, the
# same with 1 % modal damping, the same with a smooth start (no step in the case acceleration at
# t = 0), and the thesis forcing over 1 s.  They separate what the thesis scene cannot: whether a
# method's ranking survives damping of the start-up ringing, its absence, and a longer window.
STUDY_SCENES = ("thesis", "damped", "smooth", "long")
# Rate figures (truth against one case, every rate): on the thesis scene every thesis case (its
# Figures 4-2..4-27); on the other scenes the baseline and one model per family (a figure costs
# ~3 s; all cases of all scenes would be most of the main job).  Every case is in every table.
KEY_MODELS = ("rigid", "freq-10", "freq-25", "xmx-10", "xmgmx-10", "static-8",
              "static-10@2:output_motor_fz", "load-10", "global-100")
MODE_COUNTS = (5, 10, 15, 20, 25)             # Figs 4-2..4-11, Table 4.2
STATIC_COUNTS = (2, 4, 6, 8)                  # Figs 4-13..4-20, Table 4.3
CONTROL_COUNTS = STATIC_COUNTS                # freq-N without the static mode: static-N's control
GLOBAL_TOTALS = tuple(4 * n for n in MODE_COUNTS)   # global-N: as many modes as freq-N/4 in all
FIELD_FAMILIES = ("dom", "cb", "ritz")       # the field's defaults, at the thesis's counts
# cb at equal coordinates: N elastic coordinates per body, the rings' N - 6 fixed-interface modes
# plus their 6 constraint modes; the counts of freq-N (N >= 6) and of static-6, static-8 (N + 1)
CB_EQUAL_COORDINATES = tuple(n for n in MODE_COUNTS if n >= names.INTERFACE_DOFS) + \
    tuple(n + 1 for n in STATIC_COUNTS if n + 1 >= names.INTERFACE_DOFS)
LOAD_CASE_COUNT = 10                          # Figs 4-21..4-27
RANKINGS = ("xmx", "xmgmx")
# the load case of a "static-" case on the outer gimbal, where the thesis's load-case study puts it
# (Figure 4-12 / 4-24; ``names.DEFAULT_LOAD_CASE``, the static mode of every "static-" name)
DEFAULT_LOAD_CASE = names.DEFAULT_LOAD_CASE[2]
# (load case, thesis figure) in the thesis's figure order; Fig 4-24 is the default case
LOAD_CASES = (("output_motor_my", "4-21"), ("output_motor_mz", "4-22"),
              ("output_motor_fx", "4-23"), ("output_motor_fz", "4-24"),
              ("input_motor_my", "4-25"), ("input_motor_mz", "4-26"),
              ("input_motor_fx", "4-27"))
LOAD_CASE_LABELS = {"output_motor_fz": "z-force at the output motor joint",
                    "output_motor_fx": "x-force at the output motor joint",
                    "output_motor_my": "y-moment at the output motor joint",
                    "output_motor_mz": "z-moment at the output motor joint",
                    "input_motor_fx": "x-force at the input motor joint",
                    "input_motor_my": "y-moment at the input motor joint",
                    "input_motor_mz": "z-moment at the input motor joint"}
THESIS_GROUPS = ("freq", "xmx", "xmgmx", "static-freq", "static-xmx", "static-xmgmx", "load-case")
GROUPS = ("rigid", *THESIS_GROUPS, "load", "global", *FIELD_FAMILIES, "cb-equal", *REFEREES)
# Whose methods a model's group is: the thesis's selections (modes by frequency, XMX, XMGMX, with
# or without static correction modes), this project's scene-aware selections, and what the field's
# tools do by default (Craig-Bampton as Adams, Simpack, Abaqus hold a flexible body; Ritz vectors;
# dominance).  The decision names the cheapest of each for every requirement.
CAMPS = {"thesis": THESIS_GROUPS, "project": ("load", "global"), "field": (*FIELD_FAMILIES, "cb-equal")}
RANKING_TABLE_GROUPS = ("rigid", "freq", "xmx", "xmgmx", "load", "global", *FIELD_FAMILIES,
                        "cb-equal", *REFEREES)                          # Table 4.2 analogue + ours
STATIC_TABLE_GROUPS = ("static-freq", "static-xmx", "static-xmgmx", "load-case")  # Table 4.3


def study_cases(rankings=RANKINGS, static_rankings=RANKINGS, extended=True) -> list[dict]:
    """The study as a list of case records: the thesis's cases in thesis figure order, then
    (``extended``) the baseline, the controls and the scene-aware selections.

    Each record: ``model`` (model name), ``group`` (see module doc), ``ranking``
    (freq/xmx/xmgmx/load/global), ``count`` (kept vibration modes per body; global: in
    total), ``static`` (static modes per body: 0 or 1; load-case group: on the outer gimbal
    only), ``load_case`` (or None), ``thesis_figure`` ("4-2" ...), ``title``.
    """
    cases = []
    if extended:
        cases.append(_case("rigid", "rigid", None, 0, 0, None, "", "rigid bodies (no elastic mode)"))
        for n in CONTROL_COUNTS:
            cases.append(_case(f"freq-{n}", "freq", "freq", n, 0, None, "",
                               f"{n} lowest-frequency modes per body (control of static-{n})"))
    for k, n in enumerate(MODE_COUNTS):
        cases.append(_case(f"freq-{n}", "freq", "freq", n, 0, None, f"4-{2 + k}",
                           f"{n} lowest-frequency modes per body"))
    for rank in rankings:
        for k, n in enumerate(MODE_COUNTS):
            cases.append(_case(f"{rank}-{n}", rank, rank, n, 0, None, f"4-{7 + k}",
                               f"{n} {rank.upper()}-ranked modes per body"))
    for k, n in enumerate(STATIC_COUNTS):
        cases.append(_case(f"static-{n}", "static-freq", "freq", n, 1, DEFAULT_LOAD_CASE,
                           f"4-{13 + k}", f"1 static mode + {n} lowest-frequency modes per body"))
    for rank in static_rankings:
        for k, n in enumerate(STATIC_COUNTS):
            cases.append(_case(f"static-{rank}-{n}", f"static-{rank}", rank, n, 1,
                               DEFAULT_LOAD_CASE, f"4-{17 + k}",
                               f"1 static mode + {n} {rank.upper()}-ranked modes per body"))
    for case, fig in LOAD_CASES:
        cases.append(_case(f"static-{LOAD_CASE_COUNT}@2:{case}", "load-case", "freq",
                           LOAD_CASE_COUNT, 1, case, fig,
                           f"{LOAD_CASE_COUNT} lowest modes per body + static mode of the outer "
                           f"gimbal ({LOAD_CASE_LABELS[case]})"))
    if extended:
        for n in MODE_COUNTS:
            cases.append(_case(f"load-{n}", "load", "load", n, 0, None, "",
                               f"{n} modes per body ranked by the scene's joint loads"))
        for n in GLOBAL_TOTALS:
            cases.append(_case(f"global-{n}", "global", "global", n, 0, None, "",
                               f"{n} modes in total, pooled over the bodies by the scene's loads"))
        titles = {"dom": "{n} dominance-ranked modes per body",
                  "cb": "Craig-Bampton: {n} fixed-interface + 6 constraint modes per ring",
                  "ritz": "{n} load-dependent Ritz vectors per body"}
        for family in FIELD_FAMILIES:
            for n in MODE_COUNTS:
                cases.append(_case(f"{family}-{n}", family, family, n, 0, None, "",
                                   titles[family].format(n=n)))
        for n in CB_EQUAL_COORDINATES:
            cases.append(_case(cb_equal(n), "cb-equal", "cb", n, 0, None, "",
                               f"Craig-Bampton with {n} elastic coordinates per body"))
        cases.append(_case(TRUTH_CHECK, "truth-check", "freq", 100, 1, DEFAULT_LOAD_CASE, "",
                           "truth + 1 static mode per body (residual flexibility)"))
        cases.append(_case(TRUTH_INTERFACE, "truth-interface", "cb", names.TRUTH_MODES, 0, None, "",
                           "Craig-Bampton with all 100 fixed-interface modes (the truth's band plus "
                           "the interface's static flexibility)"))
    return cases


def cb_equal(n: int) -> str:
    """The Craig-Bampton model with ``n`` elastic coordinates on every body: n - 6 fixed-interface
    modes and 6 constraint modes on each ring, the n lowest modes on the platform."""
    k = n - names.INTERFACE_DOFS
    return f"cb-{k},{k},{k},{n}"


def _case(model, group, ranking, count, static, load_case, figure, title):
    return {"model": model, "group": group, "ranking": ranking, "count": count,
            "static": static, "load_case": load_case, "thesis_figure": figure, "title": title}


def rate_figure_models(scene) -> list[str]:
    """The cases whose rate figures a scene's report shows (``KEY_MODELS`` comment)."""
    if scene == "thesis":
        return ["rigid"] + study_models(extended=False)
    return list(KEY_MODELS)


def study_models(include_truth=False, **kwargs) -> list[str]:
    """Model names of the study (``study_cases``), optionally preceded by ``truth``."""
    models_ = [c["model"] for c in study_cases(**kwargs)]
    return ([TRUTH] if include_truth else []) + models_


def describe_model(name: str) -> dict:
    """Case record of any model name (study or not), from the name alone.

    ``group`` is one of GROUPS, ``truth``, or ``other`` (e.g. per-body counts or
    several static load cases); ``count`` is the kept vibration modes per body
    (None when the bodies differ); ``n_elastic`` is the total number of elastic
    coordinates (vibration + static modes over the four bodies), None if unknown.
    """
    parsed = names.parse_or_none(name)
    n_elastic = None if parsed is None else parsed.n_coordinates
    for case in study_cases():
        if case["model"] == name:
            return {**case, "n_elastic": n_elastic}
    if name == TRUTH:
        return {**_case(TRUTH, "truth", "freq", 100, 0, None, "", names.label("truth")),
                "n_elastic": n_elastic}
    return {**_case(name, "other", None, None, 0, None, "", name), "n_elastic": n_elastic}


def classify(model: str) -> tuple[str, object]:
    """(group, key) of a model name: the study group (GROUPS, ``truth``, or ``other``) and its
    key: the count per body (global: the total count), the load case for the load-case group,
    0 for rigid, the name for ``other``.  Any name, study case or not, from ``names.parse``."""
    if model == TRUTH_CHECK:              # the truth's own error, not a reduced case
        return "truth-check", 100
    if model == TRUTH_INTERFACE:
        return "truth-interface", names.TRUTH_MODES
    parsed = names.parse_or_none(model)
    if parsed is None:
        return "other", model
    if parsed.family in (TRUTH, "rigid"):
        return parsed.family, parsed.count
    if parsed.statics:
        cases = parsed.statics.get(2, ())
        if list(parsed.statics) == [2] and len(cases) == 1 and parsed.static and parsed.family == "freq" \
                and parsed.count == LOAD_CASE_COUNT and cases[0] in dict(LOAD_CASES):
            return "load-case", cases[0]
        return "other", model
    if parsed.family == names.CB and parsed.count is None:
        rings = {parsed.counts[b] for b in names.INTERFACE_BODIES}
        n = parsed.counts[5]
        if rings == {n - names.INTERFACE_DOFS}:
            return "cb-equal", n
    if parsed.group in GROUPS:
        return parsed.group, parsed.count
    return "other", model


def check_models(model_names, n_modes=100) -> list[str]:
    """Check every name against body files of ``n_modes`` modes (``selection.check_name``: the
    grammar, the counts, the load cases; raises ``names.ModelError``); returns the names."""
    for name in model_names:
        selection.check_name(name, n_modes)
    return list(model_names)


def main(argv=None) -> int:
    """Print the study's model names, one per line (``--truth`` adds the truth model)."""
    parser = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.study.cases", description=main.__doc__)
    parser.add_argument("--truth", action="store_true", help="list the truth model first")
    args = parser.parse_args(argv)
    listed = check_models(study_models(include_truth=args.truth))
    print("\n".join(listed))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

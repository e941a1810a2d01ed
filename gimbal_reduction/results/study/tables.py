"""Error of reduced models against the truth model (thesis eq 3.53) and Tables 4.2 / 4.3.

    python -m gimbal_reduction.results.study.tables --truth results/sim/thesis/truth.h5 \\
        --cases results/sim/thesis/freq-5.h5 ... \\
        --ranking-table results/tables/errors_ranking.csv \\
        --static-table results/tables/errors_static.csv

For every gimbal rate n (gamma_dot[:, n], rad/s)::

    E_n = int e_n(t)^2 dt / int r_n(t)^2 dt,   r = truth rate, e = reduced rate - r

with both integrals by the trapezoid rule on the common output grid ``t``
(s).  E is dimensionless; E = 1 means an error as large as the signal.  The
grids must be the same (same scene and output interval): a case on another
grid is refused with a one-line error (no resampling, which would hide a
scene mismatch).

Simulation files (written by ``gimbal_reduction.solver.dynamics.simulate``): datasets ``t`` (T,) [s],
``gamma`` (T, 4) [rad], ``gamma_dot`` (T, 4) [rad/s]; attributes ``model``,
``scene``, ``integrator``, ``step`` [s], ``steps``, ``wall_time_s`` [s],
``integration_time_s`` [s], ``config_hash``, ``n_modes`` (4,); ``platform_attitude`` (T, 3, 3)
when written (then the table has the platform's attitude error against the truth, arcsec:
what an IMU designer reads next to E).  With ``--frequency-error`` (the JSON of
``run_scene --frequency-error``, ``gimbal_reduction.reduction.frequency_error``) every row also has
the model's H-infinity and H2 error against the truth over the band the scene excites (relative
to the truth's norms) and the frequency of the H-infinity error's peak [Hz]; empty for a model
the file does not hold.

Tables (CSV, one row per case, long format; the report pivots them):
``--ranking-table``: the truth row (E = 0) and groups freq, xmx, xmgmx
(Table 4.2 analogue); ``--static-table``: groups static-freq, static-xmx,
static-xmgmx, load-case (Table 4.3 analogue and Figs 4-21..4-27).  Cases
outside the study go to the ranking table with group ``other``.  Columns:
``TABLE_COLUMNS``.  ``--coordinates-table``: kept elastic coordinates against error, one row
per case of every mode family (``COORDINATE_GROUPS``: the thesis's, ours and the field's
defaults), columns ``COORDINATE_COLUMNS`` (``coordinates_per_body`` = n_elastic / 4, ``E_max``
the largest E over the four rates), sorted by family and size.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys

import numpy as np

from gimbal_reduction.results.study.cases import BODY_NAMES, STATIC_TABLE_GROUPS, describe_model, study_cases
from gimbal_reduction.solver.bodies import BODIES
from gimbal_reduction.solver.dynamics.error_measure import (ARCSEC_PER_RAD, ErrorsInputError, attitude_error,
                                           check_same_grid, error_measure)
from gimbal_reduction.solver.dynamics.simfile import read_sim
from gimbal_reduction.workflow.provenance import csv_text, provenance, write_text

RATE_COLUMNS = tuple(f"E_{BODY_NAMES[b]}" for b in BODIES)
COORDINATE_GROUPS = ("freq", "xmx", "xmgmx", "dom", "load", "global", "static-freq", "static-xmx",
                     "static-xmgmx", "cb", "cb-equal", "ritz")
COORDINATE_COLUMNS = ("group", "model", "count", "n_elastic", "coordinates_per_body", *RATE_COLUMNS,
                      "E_max", "wall_time_s")
ATTITUDE_COLUMNS = ("attitude_max_arcsec", "attitude_rms_arcsec")
FREQUENCY_COLUMNS = ("hinf_error", "h2_error", "hinf_peak_hz")
TABLE_COLUMNS = ("group", "model", "ranking", "count", "static", "load_case", "thesis_figure",
                 "n_elastic", *RATE_COLUMNS, *ATTITUDE_COLUMNS, *FREQUENCY_COLUMNS, "wall_time_s",
                 "integration_time_s", "integrator",
                 "step_s", "steps", "samples", "scene", "config_hash", "file")


def case_row(truth: dict, case: dict, frequency: dict | None = None) -> dict:
    """One table row: the case's description, E per gimbal rate, its frequency-domain error (from
    ``frequency``, the run_scene JSON, if given) and its cost attributes."""
    label = case.get("path", case.get("model", "case"))
    check_same_grid(truth["t"], case["t"], label)
    ts, cs = truth["attrs"].get("scene"), case["attrs"].get("scene")
    if ts and cs and ts != cs:
        raise ErrorsInputError(f"{label}: scene {cs!r}, the truth's is {ts!r}")
    E = error_measure(truth["t"], truth["gamma_dot"], case["gamma_dot"])
    desc = describe_model(case["model"])
    a = case["attrs"]
    n_modes = a.get("n_modes")
    n_elastic = int(np.sum(n_modes)) if n_modes is not None else desc["n_elastic"]
    row = {k: desc[k] for k in ("group", "model", "ranking", "count", "static", "load_case",
                                "thesis_figure")}
    row.update({"n_elastic": n_elastic, **{c: float(e) for c, e in zip(RATE_COLUMNS, E)},
                **dict(zip(ATTITUDE_COLUMNS, attitude_errors(truth, case))),
                **frequency_columns(frequency, case["model"]),
                "wall_time_s": _num(a.get("wall_time_s")),
                "integration_time_s": _num(a.get("integration_time_s")),
                "integrator": a.get("integrator", ""), "step_s": _num(a.get("step")),
                "steps": a.get("steps", ""), "samples": int(case["t"].size),
                "scene": a.get("scene", ""), "config_hash": a.get("config_hash", ""),
                "file": case.get("path", "")})
    return row


def attitude_errors(truth: dict, case: dict) -> tuple:
    """(largest, RMS over time) [arcsec] of the angle between the case's and the truth's
    platform attitude (``error_measure.attitude_error``; the RMS by the trapezoid rule over
    the window); NaN when a file has no ``platform_attitude``."""
    Ra, Rb = truth.get("platform_attitude"), case.get("platform_attitude")
    if Ra is None or Rb is None:
        return float("nan"), float("nan")
    a = attitude_error(Ra, Rb) * ARCSEC_PER_RAD
    t = np.asarray(truth["t"], float)
    rms = math.sqrt(np.trapezoid(a ** 2, t) / (t[-1] - t[0])) if t[-1] > t[0] else float(a[0])
    return float(a.max()), float(rms)


def frequency_columns(frequency: dict | None, model: str) -> dict:
    """FREQUENCY_COLUMNS of a model from the run_scene JSON (NaN where it has none)."""
    entry = ((frequency or {}).get("models") or {}).get(model) or {}
    return {col: _num(entry.get(key)) for col, key in zip(FREQUENCY_COLUMNS, ("hinf", "h2", "hinf_hz"))}


def read_frequency_errors(path) -> dict:
    """The run_scene frequency-error JSON; ErrorsInputError (one line) if missing or not one."""
    try:
        with open(path) as f:
            data = json.load(f)
    except (OSError, ValueError) as exc:
        raise ErrorsInputError(f"{path}: unreadable frequency-error file "
                               f"({exc.__class__.__name__})") from None
    if not isinstance(data, dict) or not isinstance(data.get("models"), dict):
        raise ErrorsInputError(f"{path}: not a frequency-error file (no 'models' mapping)")
    return data


def _num(v):
    return float(v) if v is not None and v != "" else float("nan")


def build_tables(truth: dict, cases: list[dict],
                 frequency: dict | None = None) -> tuple[list[dict], list[dict]]:
    """(ranking rows, static rows) of the cases, each sorted in study order (group, count);
    frequency: the run_scene frequency-error JSON (optional)."""
    rows = [case_row(truth, truth, frequency)] + [case_row(truth, c, frequency) for c in cases]
    seen = set()
    for r in rows:
        if r["model"] in seen:
            raise ErrorsInputError(f"model {r['model']!r} given twice")
        seen.add(r["model"])
    order = {c["model"]: i for i, c in enumerate(study_cases())}
    rows.sort(key=lambda r: (r["group"] != "truth", order.get(r["model"], len(order)), r["model"]))
    static = [r for r in rows if r["group"] in STATIC_TABLE_GROUPS]
    ranking = [r for r in rows if r["group"] not in STATIC_TABLE_GROUPS]
    return ranking, static


def coordinates_rows(rows: list[dict]) -> list[dict]:
    """The rows of the coordinates table (module docstring) from error-table rows."""
    out = []
    for r in rows:
        if r["group"] not in COORDINATE_GROUPS or r.get("n_elastic") in (None, ""):
            continue
        E = [float(r[c]) for c in RATE_COLUMNS]
        out.append({"group": r["group"], "model": r["model"], "count": r["count"],
                    "n_elastic": int(r["n_elastic"]), "coordinates_per_body": int(r["n_elastic"]) / len(BODIES),
                    **dict(zip(RATE_COLUMNS, E)), "E_max": max(E), "wall_time_s": r.get("wall_time_s")})
    order = {g: i for i, g in enumerate(COORDINATE_GROUPS)}
    return sorted(out, key=lambda r: (order[r["group"]], r["n_elastic"], r["model"]))


def format_csv(rows: list[dict]) -> str:
    """CSV text of table rows (columns TABLE_COLUMNS; floats with 8 significant digits,
    ``gimbal_reduction.workflow.provenance.csv_text``)."""
    return csv_text(rows, TABLE_COLUMNS, 8)


def read_table(path) -> list[dict]:
    """Rows of a table written by this module, numbers converted (E_*, times: float;
    count, static, n_elastic, steps, samples: int or None)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in (*RATE_COLUMNS, *ATTITUDE_COLUMNS, *FREQUENCY_COLUMNS, "wall_time_s",
                  "integration_time_s", "step_s"):
            r[k] = float(r[k]) if r.get(k) not in (None, "") else float("nan")
        for k in ("count", "static", "n_elastic", "steps", "samples"):
            r[k] = int(float(r[k])) if r.get(k) not in (None, "") else None
        r["load_case"] = r.get("load_case") or None
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m gimbal_reduction.results.study.tables",
        description="Eq 3.53 error of every case against the truth model; Table 4.2 / 4.3 analogues.")
    parser.add_argument("--truth", required=True, help="truth simulation file (results/sim/{scene}/truth.h5)")
    parser.add_argument("--cases", nargs="+", required=True, help="reduced-model simulation files")
    parser.add_argument("--ranking-table", required=True, help="CSV: truth, freq, xmx, xmgmx cases")
    parser.add_argument("--static-table", required=True, help="CSV: static and load-case cases")
    parser.add_argument("--frequency-error", help="JSON of run_scene --frequency-error: H-inf and H2 "
                                                  "columns")
    parser.add_argument("--coordinates-table", help="CSV: kept elastic coordinates against E, every family")
    args = parser.parse_args(argv)
    try:
        truth = read_sim(args.truth)
        cases = [read_sim(p) for p in args.cases if os.path.abspath(p) != os.path.abspath(args.truth)]
        frequency = read_frequency_errors(args.frequency_error) if args.frequency_error else None
        ranking, static = build_tables(truth, cases, frequency)
    except ErrorsInputError as exc:
        print(f"gimbal_reduction.results.study.tables: error: {exc}", file=sys.stderr)
        return 2
    # the simulations' config hashes (and the frequency-error file's, itself theirs)
    record = provenance(sources=[args.truth, *args.cases,
                                 *([args.frequency_error] if args.frequency_error else [])])
    write_text(args.ranking_table, format_csv(ranking), record)
    write_text(args.static_table, format_csv(static), record)
    if args.coordinates_table:
        write_text(args.coordinates_table, csv_text(coordinates_rows(ranking + static), COORDINATE_COLUMNS, 8),
                   record)
    print(f"gimbal_reduction.results.study.tables: {len(ranking)} rows -> {args.ranking_table}, {len(static)} rows -> "
          f"{args.static_table}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

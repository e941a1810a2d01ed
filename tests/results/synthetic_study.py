"""Synthetic simulation files in the gimbal_reduction.solver.dynamics.simulate output contract (for the results tests).

A truth run has rates r_n(t) (rad/s); a synthetic reduced case has rates
(1 + a_n) r_n(t), so eq 3.53 gives exactly E_n = a_n^2 (also for the
trapezoid rule, since e = a r pointwise).  ``amplitudes`` chooses a_n per case
so that the study's thesis findings hold (``good=True``) or fail.
"""
from __future__ import annotations

import os

import h5py
import numpy as np

from gimbal_reduction.results.study.cases import LOAD_CASES, describe_model, study_cases

T_END, DT = 0.015, 1.0e-5


def truth_rates(t):
    """(T, 4) rad/s: a slow swing plus a fast elastic ripple per gimbal."""
    t = np.asarray(t)[:, None]
    amp = np.array([1.0, 0.5, 0.2, 0.1])
    return amp * (np.sin(2 * np.pi * 2 * t) * 50 + 0.3 * np.sin(2 * np.pi * 1800 * t))


def write_sim(path, model, t, gamma_dot, wall_time_s=1.0, scene="thesis", n_modes=None,
              integrator="rk4", step=1e-6):
    """Write a simulation file with the datasets and attributes of gimbal_reduction.solver.dynamics.simulate.write_result."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    t = np.asarray(t, float)
    gd = np.asarray(gamma_dot, float)
    gamma = np.concatenate([np.zeros((1, 4)),
                            np.cumsum(0.5 * (gd[1:] + gd[:-1]) * np.diff(t)[:, None], axis=0)])
    with h5py.File(path, "w") as f:
        f["t"], f["gamma"], f["gamma_dot"] = t, gamma, gd
        g = f.create_group("energy")
        g["kinetic"] = g["potential"] = g["total"] = g["input_work"] = np.zeros_like(t)
        n = describe_model(model)["n_elastic"] or 0
        attrs = {"scene": scene, "model": model, "integrator": integrator, "step": step,
                 "steps": int(round(t[-1] / step)), "wall_time_s": float(wall_time_s),
                 "integration_time_s": 0.9 * float(wall_time_s), "config_hash": "0123456789abcdef",
                 "omega_max": 1e6, "modal_omega_max": 1e6, "stability_limit": 2.7e-6,
                 "n_modes": np.array(n_modes if n_modes is not None else [n - 3 * (n // 4)] + [n // 4] * 3),
                 "units": "in, lbf, s, rad", "created": "2026-01-01T00:00:00"}
        for k, v in attrs.items():
            f.attrs[k] = v
    return str(path)


def amplitudes(case, good=True):
    """a_n (4,) of a study case: outer > middle >> inner, platform (finding 5)."""
    g, n = case["group"], case["count"]
    if g == "freq":
        base = 3.0 / n ** 0.5
    elif g in ("xmx", "xmgmx"):
        base = (0.5 if good else 6.0) / n ** 0.5 if n < 25 else 3.0 / n ** 0.5
    elif g == "static-freq":
        base = 0.9 if n >= 6 else 1.5
    elif g in ("static-xmx", "static-xmgmx"):
        base = 1.1 if good else 0.3
    elif g == "load-case":
        k = [c for c, _ in LOAD_CASES].index(case["load_case"])
        base = 0.5 + (0.05 if good else 2.0) * (k % 3)
    else:
        base = 0.0
    return base * np.array([1.0, 0.3, 0.01, 0.005])


def write_study(folder, good=True, cases=None, scene="thesis"):
    """Truth + study cases under folder/{scene}/; returns (truth path, case paths)."""
    t = np.linspace(0.0, T_END, int(round(T_END / DT)) + 1)
    r = truth_rates(t)
    root = os.path.join(folder, scene)
    truth = write_sim(os.path.join(root, "truth.h5"), "truth", t, r, wall_time_s=3600.0,
                      n_modes=[100] * 4, scene=scene)
    paths = []
    for c in (study_cases() if cases is None else cases):
        a = amplitudes(c, good)
        n = describe_model(c["model"])["n_elastic"]
        paths.append(write_sim(os.path.join(root, c["model"] + ".h5"), c["model"], t, r * (1 + a),
                               wall_time_s=2.0 + 0.5 * n, scene=scene))
    return truth, paths


def write_tables(folder, tables_dir):
    """A synthetic study under folder/sim with its error tables and findings in tables_dir
    (gimbal_reduction.results.study.tables and .findings, as the workflow runs them): (truth, cases, ranking
    table, static table, findings JSON)."""
    from gimbal_reduction.results.study import findings, tables
    truth, cases = write_study(os.path.join(folder, "sim"))
    rt, st = os.path.join(tables_dir, "errors_ranking.csv"), os.path.join(tables_dir, "errors_static.csv")
    assert tables.main(["--truth", truth, "--cases", *cases, "--ranking-table", rt,
                        "--static-table", st]) == 0
    fj = os.path.join(tables_dir, "findings.json")
    assert findings.main(["--ranking-table", rt, "--static-table", st,
                          "--csv", os.path.join(tables_dir, "findings.csv"), "--json", fj]) == 0
    return truth, cases, rt, st, fj

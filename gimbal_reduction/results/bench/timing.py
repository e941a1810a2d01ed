"""The median wall time of a run of a scene, within a time budget: whole runs where they fit,
else runs of a prefix of the scene scaled to the whole run by its step count.

A timing job reports the median of ``repeats`` runs in one process.  A run of the whole scene
that takes T seconds costs ``repeats * T``; where that exceeds the budget B, the job times
``repeats`` runs of the first k output intervals instead, k chosen so that one such run takes
about B / repeats at the whole run's pace (at least one interval), and scales the median by
the step count:

    t_whole ~= median(t_prefix) * N_whole / N_prefix,

N the steps the integrator took.  For a fixed-step method (RK4, generalised-alpha) the cost of a
step does not depend on where in the scene it is, so this is the whole run's time up to the
per-run overhead (microseconds against the tenth of a second a prefix run takes); for an
adaptive one (DOP853, the exponential integrator) it assumes the prefix's steps cost what the
average step costs, and the record says which basis a number has (``time_basis``).
"""
from __future__ import annotations

import math

import numpy as np


def prefix_duration(whole_wall_s, duration, dt, per_run_s):
    """[s] the prefix of a scene of ``duration`` [s] sampled every ``dt`` [s] (whole output
    intervals, at least one, at most all) a run of which takes about ``per_run_s`` [s], at the
    pace of a whole run that took ``whole_wall_s`` [s]."""
    n = max(1, int(round(duration / dt)))
    k = math.floor(n * per_run_s / max(whole_wall_s, 1e-12))
    return dt * min(n, max(1, k))


def median_timing(run, duration, dt, whole_wall_s, whole_steps, repeats, budget_s):
    """The median wall time [s] of ``repeats`` runs of the whole scene, measured or scaled.

    run(d): one run over the first d seconds of the scene (an object with ``wall_time`` [s]
    and ``steps``); whole_wall_s, whole_steps: a whole run's wall time (an estimate: it chooses
    whole runs or a prefix) and step count; budget_s: seconds of timed runs (None: no limit).
    Returns {wall_time_s, wall_time_min_s, runs, time_basis, wall_times_s (the timed runs,
    of the prefix where scaled), duration_timed_s}."""
    if budget_s is None or whole_wall_s * repeats <= budget_s:
        walls = [run(duration).wall_time for _ in range(repeats)]
        return {"wall_time_s": float(np.median(walls)), "wall_time_min_s": float(np.min(walls)),
                "runs": len(walls), "time_basis": "measured", "wall_times_s": walls,
                "duration_timed_s": duration}
    prefix = prefix_duration(whole_wall_s, duration, dt, budget_s / repeats)
    walls, steps = [], 0
    for _ in range(repeats):
        r = run(prefix)
        walls.append(r.wall_time)
        steps = r.steps
    scale = whole_steps / max(steps, 1)
    return {"wall_time_s": float(np.median(walls)) * scale,
            "wall_time_min_s": float(np.min(walls)) * scale, "runs": len(walls),
            "time_basis": f"extrapolated from {steps} of {whole_steps} steps",
            "wall_times_s": walls, "duration_timed_s": prefix}

"""The median wall time of a run of a scene, within a time budget: whole runs where they fit,
else runs of a prefix of the scene scaled to the whole run by its step count.

A timing job reports the median of ``repeats`` runs in one process.  A run of the whole scene
that takes T seconds costs ``repeats * T``; where that exceeds the budget B, the job times
``repeats`` runs of the first k output intervals instead (k chosen so that one such run takes
about B / repeats at the whole run's pace, at least two) and as many of the first interval alone,
and takes the whole run's time on the line through the two medians in the step count N:

    t_whole ~= t_1 + (t_k - t_1) * (N_whole - N_1) / (N_k - N_1),

so that a run's fixed cost is counted once, not N_whole / N_k times.  For a fixed-step method
(RK4, generalised-alpha) the cost of a step does not depend on where in the scene it is, so this
is the whole run's time; DOP853 on these scenes is stability-limited, its steps nearly uniform.
The exponential integrator's steps are not (``scalable`` False); the record says which basis a
number has (``time_basis``).
"""
from __future__ import annotations

import math

import numpy as np


def prefix_duration(whole_wall_s, duration, dt, per_run_s):
    """[s] the prefix of a scene of ``duration`` [s] sampled every ``dt`` [s] (whole output
    intervals, at least two, at most all) a run of which takes about ``per_run_s`` [s], at the
    pace of a whole run that took ``whole_wall_s`` [s]."""
    n = max(1, int(round(duration / dt)))
    k = math.floor(n * per_run_s / max(whole_wall_s, 1e-12))
    return dt * min(n, max(2, k))


def median_timing(run, duration, dt, whole_wall_s, whole_steps, repeats, budget_s, scalable=True):
    """The median wall time [s] of ``repeats`` runs of the whole scene, measured or scaled.

    run(d): one run over the first d seconds of the scene (an object with ``wall_time`` [s]
    and ``steps``); whole_wall_s, whole_steps: a whole run's wall time (an estimate: it chooses
    whole runs or a prefix) and step count; budget_s: seconds of timed runs (None: no limit).
    scalable: False for a method whose cost per step varies along the scene (the exponential
    integrator: its bases fall where the motion needs them, so a prefix misjudges the whole run
    by a factor of 3 either way on `long` and `damped`): a slow run is then timed whole, as many
    times as fit in the budget (at least once).
    Returns {wall_time_s, wall_time_min_s, runs, time_basis, wall_times_s (the timed runs,
    of the prefix where scaled), duration_timed_s}."""
    fits = budget_s is None or whole_wall_s * repeats <= budget_s
    if fits or not scalable:
        count = repeats if fits else max(1, min(repeats, int(budget_s // max(whole_wall_s, 1e-12))))
        walls = [run(duration).wall_time for _ in range(count)]
        return {"wall_time_s": float(np.median(walls)), "wall_time_min_s": float(np.min(walls)),
                "runs": len(walls), "time_basis": "measured", "wall_times_s": walls,
                "duration_timed_s": duration}
    prefix = prefix_duration(whole_wall_s, duration, dt, budget_s / repeats)
    walls, firsts, steps, first_steps = [], [], 0, 0
    for _ in range(repeats):
        r = run(dt)
        firsts.append(r.wall_time)
        first_steps = r.steps
        r = run(prefix)
        walls.append(r.wall_time)
        steps = r.steps

    def whole(t_1, t_k):
        return whole_from_prefix(t_1, first_steps, t_k, steps, whole_steps)
    return {"wall_time_s": whole(float(np.median(firsts)), float(np.median(walls))),
            "wall_time_min_s": whole(float(np.min(firsts)), float(np.min(walls))), "runs": len(walls),
            "time_basis": f"extrapolated from {steps} and {first_steps} of {whole_steps} steps",
            "wall_times_s": walls, "duration_timed_s": prefix}


def whole_from_prefix(t_1, n_1, t_k, n_k, whole_steps):
    """[s] a whole run's time on the line through (n_1, t_1), the first interval's steps and time,
    and (n_k, t_k), the prefix's (the module doc); proportional to t_k if n_k <= n_1."""
    if n_k <= n_1:
        return t_k * whole_steps / max(n_k, 1)
    return t_1 + max(t_k - t_1, 0.0) * (whole_steps - n_1) / (n_k - n_1)

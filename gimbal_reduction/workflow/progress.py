"""Progress lines of long jobs: how far, the time elapsed and an estimate of the time left.

Every long stage reports through this one helper, on stderr (the job's log under Snakemake),
at most one line every ``EVERY`` seconds, so a log stays short and a job shorter than that
prints none::

    progress: modes stable_platform: 40 of 100 eigenpairs (40 %), 12 s elapsed, ~18 s left

The time left is the mean rate so far extrapolated (``time_left``): elapsed (total - done) /
done.  Work whose units cost unequal time can be counted in weights (``Progress.advance(w)``,
e.g. an error evaluation weighted by the size of its kept set), so the estimate stays fair.
Users: the SLEPc eigen solve (converged pairs of requested, ``gimbal_reduction.solver.fe.eigen``), the
integrators (simulated time, ``gimbal_reduction.solver.dynamics.integrators``), the load-aware ranking
(``gimbal_reduction.reduction.load_aware``), the study runner (models of a scene, ``gimbal_reduction.results.study.run_scene``),
the truth-basis check and the dynamics verification (``gimbal_reduction.results.bench``), the FE convergence
check (``gimbal_reduction.solver.fe.checks``).
"""
from __future__ import annotations

import math
import sys
import time

# at most one progress line this often [s]; 0 prints every update (tests)
EVERY = 10.0


def time_left(elapsed: float, done: float, total: float) -> float | None:
    """Seconds left at the mean rate so far, elapsed (total - done) / done; None while nothing is
    done (no rate yet), 0 once done >= total."""
    if done <= 0 or not math.isfinite(elapsed) or elapsed < 0:
        return None
    return max(0.0, elapsed * (total - done) / done)


def _number(x) -> str:
    return f"{x:.0f}" if float(x) == int(x) else f"{x:.4g}"


def progress_line(label: str, done: float, total: float, elapsed: float, unit: str | None = "",
                  note: str = "") -> str:
    """``progress: LABEL: DONE of TOTAL UNIT (P %), E s elapsed, ~L s left[; NOTE]``; with unit
    None (work counted in weights, not in units worth naming) ``LABEL: P % of the work, ...``."""
    done = min(done, total)
    share = done / total if total > 0 else 1.0
    left = time_left(elapsed, done, total)
    if unit is None:
        what = f"{100 * share:.0f} % of the work"
    else:
        what = f"{_number(done)} of {_number(total)}" + (f" {unit}" if unit else "") + f" ({100 * share:.0f} %)"
    tail = "time left unknown" if left is None else f"~{left:.0f} s left"
    return f"progress: {label}: {what}, {elapsed:.0f} s elapsed, {tail}" + (f"; {note}" if note else "")


class Progress:
    """Progress of one job (or one step of a job) of ``total`` units.

    update(done) / advance(amount) record the work done and print a ``progress_line`` when
    ``every`` seconds (default ``EVERY``) have passed since the start or the last line.
    stream: where lines go (default: sys.stderr when printing); quiet: print nothing (e.g. on
    MPI ranks other than 0); clock: seconds (tests pass a fake one).  ``lines`` keeps the lines."""

    def __init__(self, label: str, total: float, unit: str | None = "", every: float | None = None,
                 stream=None, quiet: bool = False, clock=time.perf_counter):
        self.label, self.total, self.unit = label, float(total), unit
        self.every = EVERY if every is None else float(every)
        self.stream, self.quiet, self.clock = stream, quiet, clock
        self.started = self.last = clock()
        self.done = 0.0
        self.lines: list[str] = []

    @property
    def elapsed(self) -> float:
        return self.clock() - self.started

    def left(self) -> float | None:
        """The estimated time left [s] (``time_left``), None before any work is done."""
        return time_left(self.elapsed, self.done, self.total)

    def update(self, done: float, note: str = "", force: bool = False) -> str | None:
        """Record ``done`` units; print and return a line if one is due (or ``force``)."""
        self.done = float(done)
        now = self.clock()
        if not force and now - self.last < self.every:
            return None
        self.last = now
        line = progress_line(self.label, self.done, self.total, now - self.started, self.unit, note)
        self.lines.append(line)
        if not self.quiet:
            print(line, file=self.stream or sys.stderr, flush=True)
        return line

    def advance(self, amount: float = 1.0, note: str = "") -> str | None:
        """Add ``amount`` units of work done (``update``)."""
        return self.update(self.done + amount, note)

    def counted(self, fn, weight=None, note=None):
        """``fn`` wrapped so that each call advances by ``weight(*args)`` (default 1); note: a
        callable giving the line's note (e.g. the step under way)."""
        def wrapped(*args, **kwargs):
            out = fn(*args, **kwargs)
            self.advance(1.0 if weight is None else weight(*args, **kwargs), note() if note else "")
            return out
        return wrapped

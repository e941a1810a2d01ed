"""Issue 16: long jobs report progress with an estimate of the time left (gimbal_reduction.workflow.progress)."""
import re

import numpy as np
import pytest
import scipy.sparse as sp

from gimbal_reduction.workflow import progress
from gimbal_reduction.workflow.progress import Progress, progress_line, time_left

LINE = re.compile(r"^progress: .+: .+, \d+ s elapsed, (~\d+ s left|time left unknown)(; .*)?$")


class Clock:
    """A fake clock: seconds set by the test."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def test_time_left_is_the_mean_rate_extrapolated():
    assert time_left(10.0, 1, 4) == pytest.approx(30.0)       # 10 s per unit, 3 units left
    assert time_left(12.0, 3, 4) == pytest.approx(4.0)
    assert time_left(7.5, 0.25, 1.0) == pytest.approx(22.5)   # fractions (simulated time, weights)
    assert time_left(5.0, 0, 4) is None                       # no rate before anything is done
    assert time_left(5.0, 4, 4) == 0.0 and time_left(5.0, 5, 4) == 0.0


def test_progress_line_format():
    line = progress_line("modes body2", 40, 100, 12.2, "eigenpairs", "restart 3")
    assert line == "progress: modes body2: 40 of 100 eigenpairs (40 %), 12 s elapsed, ~18 s left; restart 3"
    assert progress_line("x", 0, 3, 1.0, "models") == \
        "progress: x: 0 of 3 models (0 %), 1 s elapsed, time left unknown"
    # work counted in weights: a share, not units
    assert progress_line("ranking", 2.5e6, 1e7, 30.0, None) == \
        "progress: ranking: 25 % of the work, 30 s elapsed, ~90 s left"
    assert progress_line("t", 0.0015, 0.003, 2.0, "s") == \
        "progress: t: 0.0015 of 0.003 s (50 %), 2 s elapsed, ~2 s left"
    assert progress_line("over", 7, 5, 3.0, "u").startswith("progress: over: 5 of 5 u (100 %)")


def test_lines_are_rate_limited(capsys):
    clock = Clock()
    p = Progress("job", 10, "steps", every=10.0, clock=clock)
    printed = []
    for step, seconds in enumerate((1, 5, 11, 15, 22, 23), 1):
        clock.now = 100.0 + seconds
        printed.append(p.update(step))
    assert [line is not None for line in printed] == [False, False, True, False, True, False]
    assert printed[2] == "progress: job: 3 of 10 steps (30 %), 11 s elapsed, ~26 s left"
    assert printed[4] == "progress: job: 5 of 10 steps (50 %), 22 s elapsed, ~22 s left"
    assert capsys.readouterr().err.splitlines() == [printed[2], printed[4]]      # on stderr
    assert p.update(6, force=True) is not None and capsys.readouterr().err
    quiet = Progress("rank 1", 3, quiet=True, every=0.0, clock=clock)
    assert quiet.update(1) and not capsys.readouterr().err


def test_counted_work_in_weights(capsys):
    clock = Clock()
    p = Progress("weighted", 10.0, None, every=0.0, clock=clock)
    step = "first"
    f = p.counted(lambda n: n * n, weight=lambda n: float(n), note=lambda: step)
    clock.now = 102.0
    assert f(2) == 4 and p.done == 2.0
    step = "second"
    clock.now = 110.0
    f(3)
    assert capsys.readouterr().err.splitlines() == [
        "progress: weighted: 20 % of the work, 2 s elapsed, ~8 s left; first",
        "progress: weighted: 50 % of the work, 10 s elapsed, ~10 s left; second"]


def test_the_eigen_solve_reports_converged_pairs(monkeypatch, capsys):
    """The modal stage's SLEPc solve prints converged pairs of the requested (a SLEPc monitor)."""
    from gimbal_reduction.solver.fe import eigen
    monkeypatch.setattr(progress, "EVERY", 0.0)
    n = 400
    K = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsr()
    values, _ = eigen.lowest_eigenpairs(eigen.scipy_to_petsc(K), eigen.scipy_to_petsc(sp.identity(n).tocsr()),
                                        12, 0.0, label="chain")
    assert np.allclose(values, 2 - 2 * np.cos(np.arange(1, 13) * np.pi / (n + 1)), rtol=1e-8)
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("progress: eigen solve chain: ")]
    assert lines and all(LINE.match(line) for line in lines), lines
    assert lines[-1].startswith("progress: eigen solve chain: 12 of 12 eigenpairs (100 %)")

"""Issue 16: a long integration reports its progress with the time left (integrators.PROGRESS_EVERY)."""
import re

from gimbal_reduction.results.bench.oracle import synthetic_chain
from gimbal_reduction.solver.dynamics import integrators, multibody
from gimbal_reduction.solver.dynamics.problem import Problem


def test_a_long_run_prints_progress_with_time_left(monkeypatch, capsys):
    monkeypatch.setattr(integrators, "PROGRESS_EVERY", 0.0)   # every output sample counts as "long"
    chain, _ = synthetic_chain(seed=2)
    case = multibody.CaseMotion(amplitude=(1.0, 0.0, 0.0), frequency=(2.0, 0.0, 0.0))
    integrators.integrate(Problem(chain, case=case), 2e-3, 5e-4, method="dop853", model="m")
    lines = capsys.readouterr().err.splitlines()
    progress = [line for line in lines if line.startswith("progress: dop853 m: ")]
    assert len(progress) == 3, lines            # samples 1..3 of 0..4 (none at the start or the end)
    assert all(re.search(r"\(\d+ %\), \d+ s elapsed, ~\d+ s left$", line) for line in progress), progress

"""`all`'s dynamics verification takes the truth's default DOP853 run from the converged reference
of thesis (gimbal_reduction.results.bench.verify_dynamics.reference_run): that file only, in one
line otherwise; its convergence is checked against the exponential integrator's tight run of thesis
(second_method_run, second_method_check)."""
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from gimbal_reduction.results.bench.verify_dynamics import (_shared_record, main, pareto_truth_rows,
                                                            reference_run, second_method_check,
                                                            second_method_run)
from gimbal_reduction.solver.dynamics import scenes, simulate


def sim_file(path, **attrs):
    """A minimal simulation file: 11 samples of the thesis grid, the given attributes."""
    t = np.linspace(0.0, 1e-4, 11)
    with h5py.File(path, "w") as f:
        f["t"] = t
        f["gamma_dot"] = np.outer(np.sin(t * 1e4), [1.0, 2.0, 3.0, 4.0])
        for k, v in attrs.items():
            f.attrs[k] = v
    return str(path)


REFERENCE = {"scene": "thesis", "model": "truth", "integrator": simulate.REFERENCE["integrator"],
             "stat_rtol": simulate.REFERENCE["rtol"], "stat_atol": simulate.REFERENCE["atol"],
             "steps": 21464, "integration_time_s": 16.5}


def test_the_reference_is_taken_as_the_default_run(tmp_path):
    scene = scenes.load_scene("thesis")
    run, seconds = reference_run(sim_file(tmp_path / "ref.h5", **REFERENCE), scene)
    assert run.steps == 21464 and seconds == 16.5
    assert run.step == pytest.approx(scene.duration / 21464) and run.yd.shape == (11, 4)


@pytest.mark.parametrize("change", [{"integrator": "exponential"}, {"stat_rtol": 1e-8},
                                    {"model": "freq-10"}, {"scene": "damped"}])
def test_another_run_is_refused_in_one_line(tmp_path, change):
    assert_refused_in_one_line(reference_run, sim_file(tmp_path / "other.h5", **{**REFERENCE, **change}),
                               change)


def assert_refused_in_one_line(reader, path, change):
    """``reader`` refuses the file of thesis ``path`` in one line naming it and every changed value."""
    with pytest.raises(ValueError) as err:
        reader(path, scenes.load_scene("thesis"))
    message = str(err.value)
    assert "other.h5" in message and "\n" not in message
    assert all(str(v) in message for v in change.values())


# ---- the truth's convergence against a second method (--convergence-reference)
SECOND = {"scene": "thesis", "model": "truth", "integrator": "exponential",
          "stat_exponential_tol": 1e-7, "steps": 1268}


def test_the_second_method_is_the_exponential_truth_of_thesis(tmp_path):
    run = second_method_run(sim_file(tmp_path / "exp.h5", **SECOND), scenes.load_scene("thesis"))
    assert run.steps == 1268 and run.tol == 1e-7 and run.yd.shape == (11, 4)


@pytest.mark.parametrize("change", [{"integrator": "dop853"}, {"model": "global-100"},
                                    {"scene": "damped"}])
def test_another_second_method_run_is_refused_in_one_line(tmp_path, change):
    assert_refused_in_one_line(second_method_run, sim_file(tmp_path / "other.h5", **{**SECOND, **change}),
                               change)


def _run(t, yd, **extra):
    return SimpleNamespace(t=t, yd=yd, steps=len(t), **extra)


def test_two_methods_agreeing_pass_and_disagreeing_fail():
    """E (eq. 3.53) of the default against the second method: a relative deviation d of every rate
    gives E = d^2 per rate; 1e-6 (E 1e-12) is converged, 1e-4 (E 1e-8) is not (bound 1e-10)."""
    t = np.linspace(0.0, 1e-3, 201)
    yd = np.outer(np.sin(t * 5e3) + 2.0, [1.0, 2.0, 3.0, 4.0])
    default = _run(t, yd)
    for d, passed in ((1e-6, True), (1e-4, False)):
        rec = second_method_check(default, _run(t, yd * (1 + d), tol=1e-7), "dop853",
                                  default={"rtol": 1e-10}, default_run="the reference file")
        assert rec["passed"] is passed
        assert rec["value"] == pytest.approx(d * d, rel=1e-3)
        assert "exponential integrator at tol 1e-07" in rec["name"]
    with pytest.raises(ValueError, match="outputs"):
        second_method_check(default, _run(t[:-1], yd[:-1], tol=1e-7), "dop853")


@pytest.mark.parametrize("args, word", [(["--convergence-reference", "x.h5"], "--reference"),
                                        (["--conservation-duration", "0"], "conservation"),
                                        (["--conservation-duration", "11"], "conservation")])
def test_bad_options_are_refused_in_one_line(tmp_path, capsys, args, word):
    files = [str(tmp_path / f"b{n}.h5") for n in range(4)]
    rc = main(["--bodies", *files, "--reductions", *files, "--verification", str(tmp_path / "v.json"),
               "--benchmark", str(tmp_path / "b.json"), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and word in err[0]
    assert not (tmp_path / "v.json").exists()


# ---- --runs-from: the truth's untimed RK4 and generalised-alpha runs of the Pareto benchmark
PARETO_HEADER = ("model,integrator,method,step_s,steps,wall_time_s,E,E_outer_gimbal,E_middle_gimbal,"
                 "E_inner_gimbal,E_stable_platform,status\n")


def _pareto_csv(path, *rows):
    path.write_text(PARETO_HEADER + "".join(rows))
    return str(path)


def test_the_truths_pareto_rows_give_the_records_of_the_same_step(tmp_path):
    path = _pareto_csv(tmp_path / "p.csv",
                       "freq-10,rk4-1,rk4,4.16667e-07,36000,3.0,0.07,0.07,1e-3,1e-6,3e-3,ok\n",
                       "truth,rk4-1,rk4,4.16667e-07,36000,9.1,5.9e-06,5.9e-06,2.7e-07,1.3e-09,5.6e-08,ok\n",
                       "truth,galpha-2.5e-06,generalized-alpha,2.5e-06,6000,8.8,1e-3,1e-3,1.9e-5,4.9e-6,2.4e-5,ok\n")
    rows = pareto_truth_rows(path)
    assert [(m, h) for m, h, _ in rows] == [("rk4", 4.16667e-07), ("generalized-alpha", 2.5e-06)]
    rec = _shared_record("rk4", "rk4", 0.015 / 36000, rows, path)          # the step to 6 digits
    assert rec["steps_taken"] == 36000 and rec["E_vs_converged_truth"] == 5.9e-06
    assert rec["E_per_rate"] == [5.9e-06, 2.7e-07, 1.3e-09, 5.6e-08] and "rk4-1" in rec["run_from"]
    assert _shared_record("rk4", "rk4", 0.015 / 72000, rows, path) is None  # another step: none
    assert _shared_record("ga", "generalized-alpha", 2.5e-06, rows, path)["wall_times_s"] == [8.8]


@pytest.mark.parametrize("rows, word", [(["freq-10,rk4-1,rk4,4e-07,36000,3.0,0.07,0.07,0,0,0,ok\n"], "no row"),
                                        (["truth,rk4-1,rk4,4e-07,36000,9.1,,,,,,ok\n"], "without")])
def test_pareto_rows_without_the_truth_or_its_error_are_refused(tmp_path, rows, word):
    with pytest.raises(ValueError, match=word):
        pareto_truth_rows(_pareto_csv(tmp_path / "p.csv", *rows))


def test_runs_from_needs_the_untimed_converged_referee(tmp_path, capsys):
    files = [str(tmp_path / f"b{n}.h5") for n in range(4)]
    rc = main(["--bodies", *files, "--reductions", *files, "--verification", str(tmp_path / "v.json"),
               "--benchmark", str(tmp_path / "b.json"), "--runs-from", "p.csv"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--runs-from" in err[0]

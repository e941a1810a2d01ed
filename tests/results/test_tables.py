"""gimbal_reduction.results.study.cases and gimbal_reduction.results.study.tables: case list, eq 3.53 against closed forms, tables, one-line errors."""
from __future__ import annotations

import json

import numpy as np
import pytest

from gimbal_reduction.results.study import tables
from gimbal_reduction.results.study.cases import LOAD_CASES, check_models, describe_model, study_cases, study_models
from gimbal_reduction.results.study.tables import TABLE_COLUMNS, build_tables, read_table
from gimbal_reduction.solver.dynamics.error_measure import (ErrorsInputError, check_same_grid, check_sampling,
                                                             error_measure, resolving_interval)
from gimbal_reduction.solver.dynamics.simfile import read_sim
from tests.results.synthetic_study import T_END, truth_rates, write_sim, write_study


def test_study_cases_cover_the_thesis_figures_and_parse():
    thesis = study_cases(extended=False)
    assert len(thesis) == len({c["model"] for c in thesis}) == 5 + 10 + 4 + 8 + 7
    assert [c["model"] for c in thesis[:5]] == ["freq-5", "freq-10", "freq-15", "freq-20", "freq-25"]
    cases = study_cases()
    models = [c["model"] for c in cases]
    # + the rigid baseline, the no-static controls freq-2..8, load-5..25, global-20..100, static-100,
    # the field's defaults dom-, cb-, ritz-5..25 and cb at the coordinates of freq-10..25, static-6, -8, cb-100
    assert len(models) == len(set(models)) == 34 + 1 + 4 + 5 + 5 + 1 + 15 + 6 + 1
    assert describe_model("cb-4,4,4,10")["group"] == "cb-equal"
    assert describe_model("cb-4,4,4,10")["n_elastic"] == describe_model("freq-10")["n_elastic"]
    assert describe_model("cb-3,3,3,9")["n_elastic"] == describe_model("static-8")["n_elastic"]
    assert describe_model("cb-10")["n_elastic"] == 58 and describe_model("ritz-10")["n_elastic"] == 40
    assert models[0] == "rigid" and {"freq-2", "freq-8", "load-25", "global-100", "static-100"} <= set(models)
    assert describe_model("global-40")["n_elastic"] == 40 and describe_model("rigid")["n_elastic"] == 0
    assert describe_model("load-10")["n_elastic"] == 40
    assert {"xmx-5", "xmgmx-25", "static-2", "static-8", "static-xmx-4", "static-xmgmx-6"} <= set(models)
    lc = [c for c in cases if c["group"] == "load-case"]
    assert [c["thesis_figure"] for c in lc] == [f"4-{k}" for k in range(21, 28)]
    assert {c["load_case"] for c in lc} == {c for c, _ in LOAD_CASES}
    assert all(c["model"] == f"static-10@2:{c['load_case']}" for c in lc)
    check_models(study_models(include_truth=True))   # gimbal_reduction.reduction.models grammar
    assert describe_model("static-10@2:output_motor_my")["n_elastic"] == 41
    assert describe_model("static-xmx-8")["n_elastic"] == 36
    assert describe_model("freq-10,10,5,5")["group"] == "other"


def test_check_models_refuses_bad_names():
    from gimbal_reduction.reduction.models import ModelError
    with pytest.raises(ModelError):
        check_models(["static-10@2:output_motor_qq"])


@pytest.mark.parametrize("a", [0.0, 0.1, -0.5, 2.0])
def test_scaled_signal_gives_a_squared(a):
    t = np.linspace(0.0, 1.0, 2001)
    r = np.sin(2 * np.pi * 3 * t)
    assert error_measure(t, r, (1 + a) * r) == pytest.approx(a ** 2, rel=1e-12, abs=1e-15)


def test_closed_form_of_orthogonal_error():
    # r = sin(2 pi t), e = b cos(2 pi t) over one period: E = b^2 (both integrals 1/2)
    t = np.linspace(0.0, 1.0, 4001)
    r = np.sin(2 * np.pi * t)
    E = error_measure(t, r, r + 0.3 * np.cos(2 * np.pi * t))
    assert E == pytest.approx(0.09, rel=1e-6)
    # a constant offset c on r = t over [0, 1]: int c^2 / int t^2 = 3 c^2
    t = np.linspace(0.0, 1.0, 20001)
    assert error_measure(t, t, t + 0.2) == pytest.approx(3 * 0.04, rel=1e-6)


def test_columns_are_independent_and_zero_reference_is_nan():
    t = np.linspace(0.0, 0.015, 1501)
    r = truth_rates(t)
    a = np.array([0.5, 0.1, 0.01, 0.0])
    E = error_measure(t, r, r * (1 + a))
    assert E.shape == (4,)
    np.testing.assert_allclose(E, a ** 2, rtol=1e-12, atol=1e-30)
    r0 = r.copy()
    r0[:, 3] = 0.0
    assert np.isnan(error_measure(t, r0, r0 + 1.0)[3])


def test_sampling_rule_fails_where_two_modes_alias_onto_zero_and_passes_on_a_fine_grid():
    """Two error modes whose sum frequency f1 + f2 equals the sampling rate: on that grid the
    cross term of e^2 samples as a constant, and E comes out ~0 instead of its closed form 2 a^2
    (the rule must fail); on a grid that meets the rule, E is the closed form (must pass)."""
    f1, f2, a, T = 3000.0, 6900.0, 1e-2, 0.1            # Hz, Hz, 1, s (whole periods of all)

    def E_on(dt):
        t = np.linspace(0.0, T, int(round(T / dt)) + 1)
        r = np.sin(2 * np.pi * 10.0 * t)
        return error_measure(t, r, r + a * (np.sin(2 * np.pi * f1 * t) + np.sin(2 * np.pi * f2 * t)))

    coarse = 1.0 / (f1 + f2)                            # 1.01e-4 s: Nyquist 4950 Hz < f2
    with pytest.raises(ErrorsInputError, match="does not resolve"):
        check_sampling(coarse, f2, "synthetic")
    assert abs(E_on(coarse) - 2 * a ** 2) > 0.5 * 2 * a ** 2
    fine = T / np.ceil(T / resolving_interval(f2))
    check_sampling(fine, f2, "synthetic")               # no error
    assert E_on(fine) == pytest.approx(2 * a ** 2, rel=1e-2)
    assert resolving_interval(float("nan")) == float("inf")


def test_mismatched_grids_are_refused_with_one_line(tmp_path):
    t = np.linspace(0.0, T_END, 1501)
    with pytest.raises(ErrorsInputError) as exc:
        check_same_grid(t, t[:-1], "x.h5")
    assert "\n" not in str(exc.value) and "1500" in str(exc.value)
    with pytest.raises(ErrorsInputError, match="differ"):
        check_same_grid(t, t * 1.001, "x.h5")
    truth = write_sim(tmp_path / "truth.h5", "truth", t, truth_rates(t))
    t2 = np.linspace(0.0, T_END, 751)
    case = write_sim(tmp_path / "freq-5.h5", "freq-5", t2, truth_rates(t2))
    code = tables.main(["--truth", truth, "--cases", case, "--ranking-table", str(tmp_path / "r.csv"),
                        "--static-table", str(tmp_path / "s.csv")])
    assert code == 2 and not (tmp_path / "r.csv").exists()


def test_cli_missing_and_nonfinite_inputs(tmp_path, capsys):
    t = np.linspace(0.0, T_END, 101)
    truth = write_sim(tmp_path / "truth.h5", "truth", t, truth_rates(t))
    bad = truth_rates(t)
    bad[50, 0] = np.nan
    nan_case = write_sim(tmp_path / "xmx-5.h5", "xmx-5", t, bad)
    for cases in ([str(tmp_path / "nope.h5")], [nan_case]):
        code = tables.main(["--truth", truth, "--cases", *cases, "--ranking-table",
                            str(tmp_path / "r.csv"), "--static-table", str(tmp_path / "s.csv")])
        err = capsys.readouterr().err.strip()
        assert code == 2 and len(err.splitlines()) == 1 and err.startswith("gimbal_reduction.results.study.tables: error:")


def test_tables_of_the_synthetic_study(tmp_path):
    truth, cases = write_study(tmp_path / "sim")
    rt, st = tmp_path / "tables" / "errors_ranking.csv", tmp_path / "tables" / "errors_static.csv"
    ct = tmp_path / "tables" / "coordinates.csv"
    assert tables.main(["--truth", truth, "--cases", *cases, "--ranking-table", str(rt),
                        "--static-table", str(st), "--coordinates-table", str(ct)]) == 0
    rank, stat = read_table(rt), read_table(st)
    assert [r["group"] for r in rank][:1] == ["truth"]
    assert {r["group"] for r in rank} == {"truth", "freq", "xmx", "xmgmx", "rigid", "load", "global",
                                          "dom", "cb", "ritz", "cb-equal", "truth-check", "truth-interface"}
    assert {r["group"] for r in stat} == {"static-freq", "static-xmx", "static-xmgmx", "load-case"}
    assert len(rank) == 32 + 22 and len(stat) == 19
    # the coordinates table: every family's case at its size, cb counting its constraint modes
    import csv
    coords = list(csv.DictReader(ct.open()))
    assert {r["group"] for r in coords} == set(tables.COORDINATE_GROUPS)
    by_model = {r["model"]: r for r in coords}
    assert float(by_model["cb-5"]["coordinates_per_body"]) == (3 * 11 + 5) / 4
    assert float(by_model["cb-4,4,4,10"]["coordinates_per_body"]) == 10.0
    assert float(by_model["static-8"]["n_elastic"]) == 36
    r = by_model["freq-5"]
    assert float(r["E_max"]) == max(float(r[c]) for c in tables.RATE_COLUMNS)
    by = {r["model"]: r for r in rank + stat}
    assert by["truth"]["E_outer_gimbal"] == 0.0 and by["truth"]["n_elastic"] == 400
    # synthetic rates are (1 + a) r, so E = a^2 exactly (tests/test_results_synthetic.amplitudes)
    assert by["freq-5"]["E_outer_gimbal"] == pytest.approx((3.0 / 5 ** 0.5) ** 2, rel=1e-9)
    assert by["freq-5"]["E_inner_gimbal"] == pytest.approx((0.03 / 5 ** 0.5) ** 2, rel=1e-9)
    assert by["static-10@2:input_motor_fx"]["n_elastic"] == 41
    assert by["static-10@2:input_motor_fx"]["thesis_figure"] == "4-27"
    assert by["xmx-10"]["wall_time_s"] == pytest.approx(2.0 + 0.5 * 40)
    assert by["xmx-10"]["integrator"] == "rk4" and by["xmx-10"]["samples"] == 1501
    header = rt.read_text().splitlines()[0].split(",")
    assert tuple(header) == TABLE_COLUMNS


def test_frequency_columns_come_from_the_run_scene_json(tmp_path):
    truth, cases = write_study(tmp_path / "sim")
    freq = tmp_path / "frequency_error.json"
    freq.write_text(json.dumps({"models": {"truth": {"hinf": 0.0, "h2": 0.0, "hinf_hz": None},
                                           "freq-5": {"hinf": 1.5, "h2": 0.75, "hinf_hz": 5000.0}}}))
    rt, st = tmp_path / "r.csv", tmp_path / "s.csv"
    assert tables.main(["--truth", truth, "--cases", *cases, "--ranking-table", str(rt),
                        "--static-table", str(st), "--frequency-error", str(freq)]) == 0
    by = {r["model"]: r for r in read_table(rt) + read_table(st)}
    assert (by["freq-5"]["hinf_error"], by["freq-5"]["h2_error"], by["freq-5"]["hinf_peak_hz"]) == (1.5, 0.75, 5000.0)
    assert by["truth"]["hinf_error"] == 0.0 and np.isnan(by["truth"]["hinf_peak_hz"])
    assert np.isnan(by["xmx-10"]["hinf_error"])            # a model the file does not hold
    freq.write_text("[1, 2]")                               # not a frequency-error file: one line
    assert tables.main(["--truth", truth, "--cases", *cases, "--ranking-table", str(rt),
                        "--static-table", str(st), "--frequency-error", str(freq)]) == 2


def test_duplicate_case_is_refused(tmp_path):
    t = np.linspace(0.0, T_END, 51)
    truth = read_sim(write_sim(tmp_path / "truth.h5", "truth", t, truth_rates(t)))
    c = read_sim(write_sim(tmp_path / "a.h5", "freq-5", t, truth_rates(t)))
    with pytest.raises(ErrorsInputError, match="twice"):
        build_tables(truth, [c, c])

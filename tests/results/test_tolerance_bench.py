"""The tolerance bench (gimbal_reduction.results.bench.tolerance) and its equal-error comparison
(gimbal_reduction.results.bench.equal_error): pure parts on hand-made rows, the whole bench on synthetic bodies
(6 modes each, the thesis scene), one scene with the frozen chain valid and one flagged invalid."""
import csv
import json
import math
import os
import shutil

import numpy as np
import pytest

from gimbal_reduction.results.bench import equal_error as ee
from gimbal_reduction.results.bench import tolerance as tb
from gimbal_reduction.results.study.tables import RATE_COLUMNS
from tests.reduction.test_tolerance import synthetic_inputs


def row(model, n, E, **extra):
    return {"model": model, "n_elastic": n, **dict(zip(RATE_COLUMNS, [E, E / 10, 0.0, E / 2])), **extra}


TABLE = [row("truth", 400, 0.0), row("rigid", 0, 4e-2), row("freq-5", 20, 7e-2), row("freq-25", 100, 3e-3),
         row("freq-10,10,5,5", 30, 1e-9), row("static-8", 36, 1e-9), row("xmx-5", 20, 4e-2),
         row("xmx-25", 100, 5e-2), row("global-60", 60, 1.7e-2), row("global-80", 80, 6.9e-3),
         row("global-100", 100, 6.9e-3), row("load-25", 100, 1e-9)]


def test_cheapest_within_takes_the_fewest_coordinates_of_the_family_meeting_eps():
    assert ee.cheapest_within(TABLE, "freq", 1e-2)["model"] == "freq-25"
    assert ee.cheapest_within(TABLE, "global", 1e-2)["model"] == "global-80"     # tie at 6.9e-3: fewer coords
    assert ee.cheapest_within(TABLE, "global", 2e-2)["model"] == "global-60"
    assert ee.cheapest_within(TABLE, "xmx", 1e-2) is None                         # xmx-5 fails its 4e-2
    assert ee.cheapest_within(TABLE, "xmx", 4e-2)["model"] == "xmx-5"
    # per-body counts, static modes, other families and the truth are not the family's models
    assert ee.cheapest_within(TABLE, "freq", 1e-6) is None
    assert ee.family_of("freq-10,10,5,5") is None and ee.family_of("static-8") is None
    assert ee.family_of("truth") is None and ee.family_of("global-40") == "global"


def test_max_error_is_the_largest_rate_and_a_missing_rate_fails():
    r = row("freq-5", 20, 1e-3)
    assert ee.max_error(r) == pytest.approx(1e-3)
    r[RATE_COLUMNS[2]] = 5e-3                                    # another rate is the largest
    assert ee.max_error(r) == pytest.approx(5e-3)
    r[RATE_COLUMNS[3]] = float("nan")
    assert ee.max_error(r) == math.inf
    assert ee.cheapest_within([r], "freq", 1.0) is None


def test_summary_counts_within_and_methods():
    rows = [{"scene": "a", "status": "ok", "within_request": True, "method": "a-priori estimate"},
            {"scene": "a", "status": "ok", "within_request": False, "method": "a-priori estimate"},
            {"scene": "b", "status": "ok", "within_request": True, "method": "verified search"},
            {"scene": "b", "status": "refused: x", "within_request": "", "method": ""}]
    c = tb.summarise(rows, [1e-2])
    assert c["all"] == {"requests": 4, "built": 3, "refused": 1, "within_request": 2, "a_priori": 2,
                        "verified": 1}
    assert c["per_scene"]["a"]["within_request"] == 1 and c["a_priori_only"]["within_request"] == 1


@pytest.fixture(scope="module")
def bench_run(tmp_path_factory):
    """The bench's command line on synthetic bodies: scene `thesis` (frozen chain valid) and scene
    `wild` (the same physics, its ranking flagged invalid), a study table for `thesis`."""
    root = tmp_path_factory.mktemp("tol_bench")
    valid, invalid, curve = synthetic_inputs(root)
    (root / "reduction" / "load").mkdir()
    shutil.copy(valid, root / "reduction" / "load" / "thesis.h5")
    shutil.copy(invalid, root / "reduction" / "load" / "wild.h5")
    (root / "scenes").mkdir()
    source = open(os.path.join(tb.scenes.SCENES_DIR, "thesis.yaml")).read()
    (root / "scenes" / "thesis.yaml").write_text(source)
    (root / "scenes" / "wild.yaml").write_text(source.replace("name: thesis", "name: wild"))
    eps = [float(f"{curve[2]:.3g}"), float(f"{np.sqrt(curve[2] * curve[8]):.3g}")]
    table = root / "tables" / "thesis" / "errors_ranking.csv"
    table.parent.mkdir(parents=True)
    with open(table, "w", newline="") as f:
        w = csv.DictWriter(f, ["model", "n_elastic", *RATE_COLUMNS])
        w.writeheader()
        for r in (row("freq-2", 8, 0.5 * eps[0]), row("freq-6", 24, 0.0), row("global-12", 12, 0.5 * eps[1])):
            w.writerow(r)
    out = root / "out"
    rc = tb.main(["--scenes", str(root / "scenes" / "thesis.yaml"), str(root / "scenes" / "wild.yaml"),
                  "--eps", *map(str, eps), "--modes-dir", str(root / "modes"),
                  "--reduction-dir", str(root / "reduction"), "--tables-dir", str(root / "tables"),
                  "--reference", "global-24", "--repeats", "2", "--budget", "5",
                  "--out-csv", str(out / "tolerance.csv"), "--out-json", str(out / "tolerance.json"),
                  "--figure", str(out / "fig" / "tolerance.png")])
    assert rc == 0
    return out, eps, json.load(open(out / "tolerance.json"))


def test_bench_rows_measure_every_request_against_the_reference(bench_run):
    out, eps, data = bench_run
    rows = data["rows"]
    assert [(r["scene"], r["eps"]) for r in rows] == [(s, e) for s in ("thesis", "wild") for e in eps]
    for r in rows:
        assert r["status"] == "ok" and r["runs"] >= 1 and r["run_time_s"] > 0
        assert r["within_request"] == (r["measured_E_max"] <= r["eps"])
    thesis = [r for r in rows if r["scene"] == "thesis"]
    wild = [r for r in rows if r["scene"] == "wild"]
    assert all(r["method"] == "a-priori estimate" and r["frozen_chain_valid"] for r in thesis)
    assert all(r["apriori_N"] == r["n_kept"] and r["apriori_measured_E_max"] == r["measured_E_max"]
               for r in thesis)
    assert all(r["estimated_E_max"] <= r["eps"] for r in thesis)
    # the invalid scene's requests were answered by simulation, and the bench's own run agrees
    assert all(r["method"] == "verified search" and not r["frozen_chain_valid"] for r in wild)
    for r in wild:
        assert r["within_request"] and r["measured_E_max"] == pytest.approx(r["verified_E_max"], rel=1e-9)
        assert r["search_probes"] >= 1 and r["search_cost_s"] > 0
        # the frozen chain's own choice on the same physics is the a-priori scene's answer, and the
        # search measured it first
        same = next(t for t in thesis if t["eps"] == r["eps"])
        assert r["apriori_N"] == same["n_kept"]
        assert r["apriori_measured_E_max"] == pytest.approx(same["measured_E_max"], rel=1e-9)
    assert data["counts"]["all"]["verified"] == 2 and data["counts"]["all"]["a_priori"] == 2
    with open(out / "tolerance.csv") as f:
        assert len(list(csv.DictReader(f))) == 4
    assert (out / "fig" / "tolerance.png").stat().st_size > 1000 and (out / "fig" / "tolerance.pdf").exists()


def test_bench_compares_the_cheapest_family_models_at_equal_error(bench_run):
    out, eps, data = bench_run
    comp = data["comparisons"]
    assert {c["scene"] for c in comp} == {"thesis"}                # only where a study table exists
    assert len(comp) == len(eps) * len(ee.FAMILIES)
    by = {(c["family"], c["eps"]): c for c in comp}
    assert by[("freq", eps[0])]["model"] == "freq-2"               # the table's cheapest meeting eps
    assert by[("freq", eps[1])]["model"] == "freq-6"
    assert by[("global", eps[1])]["model"] == "global-12"
    assert by[("xmx", eps[0])]["model"] == ""                      # no xmx model in the table
    c = by[("freq", eps[1])]
    assert c["n_elastic"] == 24 and c["measured_E_max"] == pytest.approx(0.0, abs=1e-12)   # all modes
    assert c["time_ratio"] == pytest.approx(c["tol_run_time_s"] / c["run_time_s"])


# ---- --truths: the truth's run read from the study's file of the scene
def _truth_files(tmp_path, **change):
    """(simulation file, model file) as the study and the reduction stage write them, thesis."""
    import h5py
    from gimbal_reduction.solver.dynamics import scenes
    scene = scenes.load_scene("thesis")
    n = int(round(scene.duration / scene.output_interval)) + 1
    model = tmp_path / "truth_model.h5"
    with h5py.File(model, "w") as f:
        f.attrs["config_hash"] = "feb4"
    attrs = {"scene": "thesis", "model": "truth", "model_config_hash": "feb4",
             "integrator": "exponential", "stat_exponential_tol": 1e-5, "steps": 41,
             "integration_time_s": 0.3, **change}
    sim = tmp_path / "sim.h5"
    with h5py.File(sim, "w") as f:
        f["t"] = np.linspace(0.0, scene.duration, n)
        f["gamma_dot"] = np.ones((n, 4))
        for k, v in attrs.items():
            f.attrs[k] = v
    return str(sim), str(model), scene


def test_the_truth_is_read_from_the_studys_run(tmp_path):
    sim, model, scene = _truth_files(tmp_path)
    run = tb.file_run(sim, scene, model)
    assert run["rates"].shape == (run["t"].size, 4) and run["steps"] == 41
    assert run["run_time_s"] == 0.3 and run["runs"] == 1 and "not timed alone" in run["time_basis"]


@pytest.mark.parametrize("change", [{"scene": "damped"}, {"model": "global-100"},
                                    {"model_config_hash": "other"}, {"integrator": "rk4"},
                                    {"stat_exponential_tol": 1e-6}])
def test_another_run_is_refused_as_the_truth_in_one_line(tmp_path, change):
    sim, model, scene = _truth_files(tmp_path, **change)
    with pytest.raises(ValueError) as err:
        tb.file_run(sim, scene, model)
    assert "sim.h5" in str(err.value) and "\n" not in str(err.value)
    assert all(str(v) in str(err.value) for v in change.values())


@pytest.mark.parametrize("args", [["--truths", "thesis=x.h5"],                       # not --untimed
                                  ["--untimed", "--truths", "spin=x.h5"],            # not a scene given
                                  ["--untimed", "--truths", "thesis"]])
def test_bad_truths_are_refused_in_one_line(tmp_path, capsys, args):
    rc = tb.main(["--scenes", "thesis", "--out-csv", str(tmp_path / "t.csv"),
                  "--out-json", str(tmp_path / "t.json"), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--truths" in err[0]
    assert not (tmp_path / "t.json").exists()


# ---- --truth-times: the truth's time from the runtime benchmark of the scene
def _runtime_files(tmp_path, **change):
    """(runtime JSON, truth model file) of a synthetic truth on thesis."""
    from gimbal_reduction.results.bench.oracle import synthetic_chain
    from gimbal_reduction.solver.dynamics import chainfile, scenes
    chain, _ = synthetic_chain(seed=1)
    model = tmp_path / "truth.h5"
    chainfile.write_chain(model, chain, {b.number: np.arange(b.n_modes) for b in chain.bodies},
                          {b.number: () for b in chain.bodies}, {"model": "truth", "config_hash": "synthetic"})
    data = {"scene": "thesis", "integrator": "exponential",
            "models": {"truth": {"n_modes": [int(n) for n in chain.n_modes],
                                 "run_ms_all": [30.0, 10.0, 20.0, 50.0, 40.0]}}}
    data.update({k: v for k, v in change.items() if k != "n_modes"})
    if "n_modes" in change:
        data["models"]["truth"]["n_modes"] = change["n_modes"]
    path = tmp_path / "runtime.json"
    path.write_text(json.dumps(data))
    return str(path), str(model), scenes.load_scene("thesis")


def test_the_truth_time_is_the_runtime_benchmarks_median(tmp_path):
    path, model, scene = _runtime_files(tmp_path)
    got = tb.runtime_truth_time(path, scene, model)
    assert got["run_time_s"] == pytest.approx(0.03) and got["runs"] == 5
    assert got["time_basis"].startswith("measured: the runtime benchmark's whole runs")


@pytest.mark.parametrize("change", [{"scene": "damped"}, {"integrator": "rk4"}, {"n_modes": [1, 2, 3, 4]}])
def test_a_runtime_benchmark_of_another_run_is_refused_in_one_line(tmp_path, change):
    path, model, scene = _runtime_files(tmp_path, **change)
    with pytest.raises(ValueError) as err:
        tb.runtime_truth_time(path, scene, model)
    assert "runtime.json" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("args", [["--truth-times", "thesis=x.json"],                 # not --times-from
                                  ["--truth-times", "thesis"]])
def test_bad_truth_times_are_refused_in_one_line(tmp_path, capsys, args):
    rc = tb.main(["--scenes", "thesis", "--out-csv", str(tmp_path / "t.csv"),
                  "--out-json", str(tmp_path / "t.json"), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--truth-times" in err[0]
    assert not (tmp_path / "t.json").exists()

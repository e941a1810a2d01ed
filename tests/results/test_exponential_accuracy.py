"""gimbal_reduction.results.bench.exponential_accuracy: its argument and reference checks (one-line errors
before any integration) and its table."""

import h5py
import numpy as np
import pytest

from gimbal_reduction.results.bench import exponential_accuracy as ea


def write_reference(path, **attrs):
    base = {"scene": "thesis", "model": "truth", "model_config_hash": "abc",
            "integrator": "dop853", "stat_rtol": 1e-10}
    base.update(attrs)
    with h5py.File(path, "w") as f:
        f["t"] = np.linspace(0, 1e-3, 11)
        f["gamma_dot"] = np.zeros((11, 4))
        for k, v in base.items():
            f.attrs[k] = v
    return str(path)


def test_parse_references():
    assert ea.parse_references(["thesis=a.h5", "free=b.h5"]) == {"thesis": "a.h5", "free": "b.h5"}
    for bad in (["thesis"], ["=a.h5"], ["thesis="], ["thesis=a", "thesis=b"]):
        with pytest.raises(ea.AccuracyInputError) as exc:
            ea.parse_references(bad)
        assert "\n" not in str(exc.value)


def test_a_converged_reference_is_read(tmp_path):
    t, rates, kind = ea.read_reference("thesis", write_reference(tmp_path / "r.h5"), "abc")
    assert t.shape == (11,) and rates.shape == (11, 4) and kind == "dop853 rtol 1e-10"


def test_the_exponential_integrator_far_tighter_than_the_scene_is_a_reference(tmp_path):
    """The faster route: exponential at the scene's tolerance / EXPONENTIAL_REFERENCE_FACTOR (1e-7
    for a scene run at 1e-5) is a reference; at 1e-6 (only 10 times tighter) it is refused, and
    without the scene's tolerance (an --anchor must be DOP853) always."""
    assert ea.EXPONENTIAL_REFERENCE_FACTOR == 100.0
    tight = write_reference(tmp_path / "e.h5", integrator="exponential", stat_exponential_tol=1e-7)
    assert ea.read_reference("thesis", tight, "abc", scene_tol=1e-5)[2] == "exponential tol 1e-07"
    loose = write_reference(tmp_path / "l.h5", integrator="exponential", stat_exponential_tol=1e-6)
    for path, scene_tol in ((loose, 1e-5), (tight, None)):
        with pytest.raises(ea.AccuracyInputError) as exc:
            ea.read_reference("thesis", path, "abc", scene_tol=scene_tol)
        assert "exponential" in str(exc.value) and "\n" not in str(exc.value)


@pytest.mark.parametrize("attrs, word", [({"scene": "free"}, "scene"), ({"model": "freq-10"}, "model"),
                                         ({"model_config_hash": "zzz"}, "model"),
                                         ({"integrator": "rk4"}, "integrator"),
                                         ({"stat_rtol": 1e-6}, "rtol")])
def test_a_reference_that_is_not_the_converged_truth_is_refused(tmp_path, attrs, word):
    path = write_reference(tmp_path / "r.h5", **attrs)
    with pytest.raises(ea.AccuracyInputError) as exc:
        ea.read_reference("thesis", path, "abc")
    assert word in str(exc.value) and "\n" not in str(exc.value)


def test_a_missing_reference_is_refused_by_the_cli(tmp_path, capsys):
    rc = ea.main(["--truth-model", str(tmp_path / "none.h5"), "--reference", f"thesis={tmp_path}/x.h5",
                  "--out-json", str(tmp_path / "o.json"), "--out-md", str(tmp_path / "o.md")])
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("exponential_accuracy:")
    assert not (tmp_path / "o.json").exists()


def test_markdown_has_a_row_per_scene():
    case = {"tol": 1e-5, "E_max": 1e-9, "steps": 10, "bases": 2, "wall_s": 0.1}
    text = ea.markdown([{"scene": "thesis", "default": case, "tight": case},
                        {"scene": "free", "default": case, "tight": case}])
    assert text.count("\n| thesis |") + text.count("| thesis |") >= 1
    assert len(text.strip().splitlines()) == 4
    anchored = ea.markdown([{"scene": "thesis", "default": case, "tight": case}],
                           [{"scene": "thesis", "reference": "exponential tol 1e-07",
                             "anchor": "dop853 rtol 1e-10", "E_max": 2e-10}])
    assert "against DOP853 (dop853 rtol 1e-10): E max 2.00e-10" in anchored


def test_a_scene_is_checked_at_the_tolerance_the_workflow_runs_it_at():
    """long states exponential_tolerance 5e-7: checked at the tighter of it and the default, as
    the workflow simulates it; a scene without one at the default."""
    from gimbal_reduction.solver.dynamics import scenes
    assert scenes.load_scene("long").tighter_tolerance(1e-5) == 5e-7
    assert scenes.load_scene("long").tighter_tolerance(1e-7) == 1e-7
    assert scenes.load_scene("thesis").tighter_tolerance(1e-5) == 1e-5


def test_a_faster_reference_is_checked_against_dop853():
    """anchor_check: E (eq. 3.53) of the reference against DOP853 within ANCHOR_BOUND (1e-9) passes;
    a reference off by a relative 1e-4 of the rates (E ~ 1e-8: eq. 3.53 squares it) fails."""
    t = np.linspace(0.0, 0.015, 151)
    rates = np.stack([np.sin(2 * np.pi * 100 * t + k) for k in range(4)], axis=1)
    anchor = (t, rates, "dop853 rtol 1e-10")
    for offset, passed in ((1e-6, True), (1e-4, False)):
        row, check = ea.anchor_check("thesis", (t, rates * (1 + offset), "exponential tol 1e-08"), anchor)
        assert check["passed"] is passed and len(row["E"]) == 4
        assert check["tolerance"] == pytest.approx(1e-9)


# ---- --runs: the default case read from the workflow's own run of the scene
RUN_ATTRS = {"integrator": "exponential", "stat_exponential_tol": 1e-5, "steps": 41,
             "stat_evaluations": 45, "stat_relinearisations": 0, "stat_phase_relinearisations": 0,
             "stat_rejected": 1, "integration_time_s": 0.3, "stat_basis_time_s": 0.05}


def test_the_default_case_is_read_from_the_scenes_run(tmp_path):
    t = np.linspace(0, 1e-3, 11)
    ref = np.ones((11, 4))
    path = write_reference(tmp_path / "run.h5", **RUN_ATTRS)     # zero rates: E = 1 on every rate
    case = ea.file_case(path, "thesis", "abc", t, ref, 1e-5)
    assert case["E_max"] == pytest.approx(1.0) and case["steps"] == 41 and case["bases"] == 1
    assert case["wall_s"] == 0.3 and case["run_file"] == path


@pytest.mark.parametrize("attrs, word", [({"scene": "free"}, "scene"), ({"model": "freq-10"}, "model"),
                                         ({"stat_exponential_tol": 1e-6}, "tol"),
                                         ({"integrator": "dop853"}, "integrator")])
def test_a_run_of_another_case_is_refused_in_one_line(tmp_path, attrs, word):
    path = write_reference(tmp_path / "run.h5", **{**RUN_ATTRS, **attrs})
    with pytest.raises(ea.AccuracyInputError) as exc:
        ea.file_case(path, "thesis", "abc", np.linspace(0, 1e-3, 11), np.ones((11, 4)), 1e-5)
    assert word in str(exc.value) and "\n" not in str(exc.value)


def test_a_run_on_another_grid_is_refused(tmp_path):
    path = write_reference(tmp_path / "run.h5", **RUN_ATTRS)
    with pytest.raises(ea.AccuracyInputError, match="outputs"):
        ea.file_case(path, "thesis", "abc", np.linspace(0, 1e-3, 21), np.ones((21, 4)), 1e-5)


def test_a_run_without_its_reference_is_refused_by_the_cli(tmp_path, capsys):
    rc = ea.main(["--truth-model", str(tmp_path / "none.h5"), "--reference", f"thesis={tmp_path}/x.h5",
                  "--runs", f"free={tmp_path}/r.h5",
                  "--out-json", str(tmp_path / "o.json"), "--out-md", str(tmp_path / "o.md")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--runs" in err[0]


def test_the_reference_route_at_another_order_is_checked_against_dop853(tmp_path, capsys):
    """--anchor-orders: the anchored scene's truth integrated at its reference's tolerance with
    another Adams order (the route long's reference takes) is held against DOP853 like the
    reference itself; the reference's own order is not run twice; the route is named in its row.
    A synthetic chain (2 modes per body) on the thesis scene."""
    import json
    from gimbal_reduction.solver.dynamics import simulate, warmup
    from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain
    truth = str(tmp_path / "truth.h5")
    warmup.write_model(truth, synthetic_modal_chain(2, seed=0), "truth")
    files = {"ref": ["--integrator", "exponential", "--tol", "1e-7"],
             "dop": ["--integrator", "dop853", "--rtol", "1e-10"]}
    for name, opts in files.items():
        assert simulate.main(["--scene", "thesis", "--model-file", truth, "--out", str(tmp_path / f"{name}.h5"),
                              "--no-config-check", "--no-energy", *opts]) == 0
    out = tmp_path / "acc.json"
    ea.main(["--truth-model", truth, "--reference", f"thesis={tmp_path}/ref.h5",
             "--anchor", f"thesis={tmp_path}/dop.h5", "--anchor-orders", "2", "4",
             "--out-json", str(out), "--out-md", str(tmp_path / "acc.md")])
    anchors = json.loads(out.read_text())["anchors"]
    assert [a.get("route_order") for a in anchors] == [None, 2]         # order 4 is the reference's
    assert anchors[0]["reference"] == "exponential tol 1e-07, order 4"
    assert anchors[1]["reference"] == "exponential tol 1e-07, order 2"
    assert all(0 < a["E_max"] <= ea.ANCHOR_BOUND for a in anchors)
    capsys.readouterr()
    rc = ea.main(["--truth-model", truth, "--reference", f"thesis={tmp_path}/ref.h5", "--anchor-orders", "2",
                  "--out-json", str(tmp_path / "x.json"), "--out-md", str(tmp_path / "x.md")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--anchor-orders" in err[0]
    assert not (tmp_path / "x.json").exists()

"""gimbal_reduction.results.bench.truth_basis: the comparison of the truth with a larger basis."""
import numpy as np
import pytest

from gimbal_reduction.results.bench import truth_basis
from gimbal_reduction.solver.dynamics import multibody


def sim(rates, angle):
    t = np.linspace(0.0, 0.015, 151)
    return {"t": t, "gamma_dot": np.outer(np.sin(300 * t), rates),
            "platform_attitude": multibody._rotations(2, np.full(t.size, angle))}


def test_compare_gives_eq_3_53_and_the_attitude_angle():
    large = sim([1.0, 1.0, 1.0, 1.0], 0.0)
    truth = sim([1.1, 1.0, 0.9, 1.0], 1e-6)             # E = a^2 per rate
    out = truth_basis.compare(truth, large)
    assert out["E"] == pytest.approx([0.01, 0.0, 0.01, 0.0], abs=1e-14)
    assert out["E_max"] == pytest.approx(0.01)
    assert out["attitude_max_arcsec"] == pytest.approx(1e-6 * 180 * 3600 / np.pi, rel=1e-9)


def test_bad_body_files_fail_in_one_line(tmp_path, capsys):
    rc = truth_basis.main(["--bodies", *[str(tmp_path / f"b{n}.h5") for n in range(4)],
                           "--scenes", "config/scenes/thesis.yaml", "--out", str(tmp_path / "o.json")])
    assert rc == 2 and not (tmp_path / "o.json").exists()


def test_each_model_is_reduced_once_per_set_of_elastic_bodies(tmp_path, monkeypatch):
    """Scenes with the same elastic bodies share the reduced-model files (the damping is the
    scene's, applied when a simulation reads one); a scene with other elastic bodies gets its own."""
    from pathlib import Path

    rigid_platform = tmp_path / "rigid_platform.yaml"
    rigid_platform.write_text(Path("config/scenes/thesis.yaml").read_text().replace(
        "bodies: {value: [2, 3, 4, 5]", "bodies: {value: [2, 3, 4]").replace("name: thesis", "name: rigid_platform"))
    scenes = ["config/scenes/thesis.yaml", "config/scenes/damped.yaml", str(rigid_platform),
              "config/scenes/smooth.yaml"]
    reduced, simulated = [], []

    def reduce(argv):
        reduced.append((argv[argv.index("--model") + 1], argv[argv.index("--scene") + 1]))
        Path(argv[argv.index("--out") + 1]).write_text("model")
        return 0

    def simulate(argv):
        model_file = argv[argv.index("--model-file") + 1]
        assert Path(model_file).exists()
        simulated.append((argv[argv.index("--scene") + 1], model_file))
        return 0

    monkeypatch.setattr(truth_basis.reduction_models, "main", reduce)
    monkeypatch.setattr(truth_basis.simulate, "main", simulate)
    monkeypatch.setattr(truth_basis, "read_sim", lambda path: sim([1.0, 1.0, 1.0, 1.0], 0.0))
    out = truth_basis.run(["b2.h5", "b3.h5", "b4.h5", "b5.h5"], scenes, log=lambda *a: None)
    assert sorted(out) == ["damped", "rigid_platform", "smooth", "thesis"]
    assert sorted(reduced) == sorted([("truth", scenes[0]), (truth_basis.LARGE, scenes[0]),
                                      ("truth", scenes[2]), (truth_basis.LARGE, scenes[2])])
    assert len(simulated) == 8
    files = {scene: [f for s, f in simulated if s == scene] for scene in scenes}
    assert files[scenes[0]] == files[scenes[1]] == files[scenes[3]] != files[scenes[2]]


def truth_attrs(scene_file, model_hash, tol, **changed):
    """The attributes of the study's truth run of a scene as simulate writes them."""
    from gimbal_reduction.solver.dynamics import simulate
    from gimbal_reduction.solver.dynamics.scenes import load_scene

    scene = load_scene(scene_file)
    options = {"integrator": "exponential", "step": None, "tol": tol}
    return {"scene": scene.name, "model": "truth", "integrator": "exponential",
            "model_config_hash": model_hash, "stat_exponential_tol": tol,
            "config_hash": simulate.config_hash(scene, model_hash, options), **changed}


@pytest.mark.parametrize("changed", [{}, {"scene": "damped"}, {"model": "freq-10"}, {"integrator": "rk4"},
                                     {"model_config_hash": "0123456789abcdef"},
                                     {"stat_exponential_tol": 1e-6}, {"config_hash": "0123456789abcdef"}])
def test_the_study_truth_is_taken_only_as_the_run_this_job_would_make(monkeypatch, changed):
    """check_truth_run accepts the study's run of the same scene, truth model, integrator and
    tolerance, and refuses in one line a file differing in any of them or in the scene's
    physics (its config_hash)."""
    from gimbal_reduction.solver.dynamics.scenes import load_scene

    scene = load_scene("config/scenes/thesis.yaml")
    attrs = truth_attrs("config/scenes/thesis.yaml", "feb4a99b928bcaf3", 1e-5, **changed)
    monkeypatch.setattr(truth_basis, "read_sim", lambda path: {"attrs": attrs})
    if not changed:
        truth_basis.check_truth_run("truth.h5", scene, "feb4a99b928bcaf3", 1e-5)
        return
    with pytest.raises(ValueError) as err:
        truth_basis.check_truth_run("truth.h5", scene, "feb4a99b928bcaf3", 1e-5)
    assert "\n" not in str(err.value) and set(changed) <= set(eval(str(err.value).split("it has ")[1]))


def test_a_study_truth_is_read_instead_of_simulated(tmp_path, monkeypatch):
    """With --truths the truth of those scenes is read (after the check, before any simulation);
    only the larger basis, and the truths of scenes without a file, are simulated; the freq-200
    runs are at the scene's tolerance (long: its own, tighter)."""
    from pathlib import Path

    scenes = ["config/scenes/thesis.yaml", "config/scenes/long.yaml"]
    simulated, checked = [], []

    def reduce(argv):
        Path(argv[argv.index("--out") + 1]).write_text("model")
        return 0

    def simulate(argv):
        simulated.append((Path(argv[argv.index("--scene") + 1]).stem, Path(argv[argv.index("--model-file") + 1]).name,
                          float(argv[argv.index("--tol") + 1])))
        return 0

    monkeypatch.setattr(truth_basis.reduction_models, "main", reduce)
    monkeypatch.setattr(truth_basis.simulate, "main", simulate)
    monkeypatch.setattr(truth_basis, "model_hash", lambda path: "h")
    monkeypatch.setattr(truth_basis, "check_truth_run",
                        lambda path, scene, truth_hash, tol: checked.append((path, scene.name, tol)))
    monkeypatch.setattr(truth_basis, "read_sim", lambda path: sim([1.0, 1.0, 1.0, 1.0], 0.0))
    out = truth_basis.run(["b2.h5", "b3.h5", "b4.h5", "b5.h5"], scenes, log=lambda *a: None, tol=1e-5,
                          truths={"thesis": "study_thesis_truth.h5"})
    assert checked == [("study_thesis_truth.h5", "thesis", 1e-5)]
    assert out["thesis"]["truth_run"] == "study_thesis_truth.h5"
    assert out["long"]["truth_run"] == "simulated here"
    assert sorted(simulated) == sorted([("thesis", f"thesis_{truth_basis.LARGE}_model.h5", 1e-5),
                                        ("long", "thesis_truth_model.h5", 5e-7),
                                        ("long", f"thesis_{truth_basis.LARGE}_model.h5", 5e-7)])


@pytest.mark.parametrize("items, culprit", [(["thesis"], "not SCENE=FILE"),
                                            (["spin=x.h5"], "not among --scenes"),
                                            (["thesis=missing.h5"], "does not exist")])
def test_bad_truths_fail_in_one_line(items, culprit):
    with pytest.raises(ValueError, match=culprit):
        truth_basis.parse_truths(items, ["thesis", "long"])

"""gimbal_reduction.solver.dynamics.warmup: the one compilation before the workflow's simulations runs the
synthetic chain through the simulate command line on every scene, and says so in one line
when it cannot."""
import json
import os

import numpy as np

from gimbal_reduction.solver.dynamics import chainfile, scenes, warmup
from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain


def test_warmup_simulates_the_elastic_chain_per_scene_the_checks_integrators_and_the_rigid_chain(tmp_path):
    thesis = os.path.join(scenes.SCENES_DIR, "thesis.yaml")
    damped = os.path.join(scenes.SCENES_DIR, "damped.yaml")
    out = tmp_path / "kernels.json"
    assert warmup.main(["--scenes", thesis, damped, "--tol", "1e-6", "--out", str(out)]) == 0
    record = json.loads(out.read_text())
    assert [(r["scene"], r["model"]) for r in record["runs"]] == [(thesis, "elastic"), (damped, "elastic"),
                                                                  (thesis, "elastic"), (thesis, "elastic"),
                                                                  (thesis, "rigid")]
    assert record["runs"][0]["options"] == ["--integrator", "exponential", "--tol", "1e-6"]
    # the other integrators all's checks run (their kernels into the extension)
    assert [r["options"] for r in record["runs"][2:4]] == [["--integrator", "rk4"],
                                                           ["--integrator", "generalized-alpha"]]
    assert record["runs"][-1]["options"] == ["--integrator", "dop853"]
    # those two over the first scene's first output intervals only
    assert [r["output_intervals"] for r in record["runs"]] == [None, None, warmup.SHORT_WINDOW,
                                                               warmup.SHORT_WINDOW, None]
    assert record["git_revision"] and record["versions"] and record["wall_time_s"] > 0


def test_a_shortened_scene_is_the_same_scene_over_its_first_output_intervals(tmp_path):
    thesis = os.path.join(scenes.SCENES_DIR, "thesis.yaml")
    whole = scenes.load_scene(thesis)
    short = scenes.load_scene(warmup.shortened(thesis, 40, tmp_path))
    assert short.name == whole.name and short.output_interval == whole.output_interval
    assert np.isclose(short.duration, 40 * whole.output_interval, rtol=1e-12, atol=0)
    assert short.case == whole.case and short.initial_angles == whole.initial_angles
    # never longer than the scene itself
    assert scenes.load_scene(warmup.shortened(thesis, 10 ** 6, tmp_path)).duration == whole.duration


def test_rigid_chain_keeps_the_rigid_mass_and_drops_every_mode(tmp_path):
    chain = synthetic_modal_chain(2, seed=0)
    rigid = warmup.rigid_chain(chain)
    assert [b.n_modes for b in rigid.bodies] == [0, 0, 0, 0]
    for a, b in zip(chain.bodies, rigid.bodies):
        assert np.array_equal(a.rigid_mass, b.rigid_mass)
    # both are valid reduced-model files, as the simulations read them
    path = tmp_path / "rigid.h5"
    warmup.write_model(path, rigid, "synthetic-rigid")
    back, info = chainfile.read_chain(path)
    assert info["model"] == "synthetic-rigid" and back.n_coordinates == 4


def test_a_missing_scene_stops_the_warmup_in_one_line(tmp_path, capsys):
    out = tmp_path / "kernels.json"
    assert warmup.main(["--scenes", str(tmp_path / "nope.yaml"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("warmup: the synthetic elastic chain failed on") and "nope.yaml" in err[-1]
    assert not out.exists()

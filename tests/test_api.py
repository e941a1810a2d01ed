"""The notebook API (gimbal_reduction.api) against the workflow's own two jobs: the same model
and scene through reduce + simulate in memory, and through the command lines to files, give
the same run (an independent path: the files, the CLI's options and its damping)."""
import numpy as np
import pytest

from gimbal_reduction import api
from gimbal_reduction.solver.dynamics import scenes
from tests.dynamics_fixtures import run_model
from tests.reduction.test_models import files  # noqa: F401  (the synthetic body files)


@pytest.mark.parametrize("scene", ["thesis", "damped"])
def test_reduce_and_simulate_match_the_command_lines(files, tmp_path, scene):  # noqa: F811
    root, _ = files
    model = api.reduce("xmx-2", scene, bodies=root / "modes", reductions=root / "reduction", config=None)
    assert model.name == "xmx-2" and model.n_elastic == 8 and model.chain.n_modes == (2, 2, 2, 2)
    run = api.simulate(model, scene)
    grid = scenes.load_scene(scene)
    n = int(round(grid.duration / grid.output_interval)) + 1          # the scene's output samples
    assert run.t.shape == (n,) and run.gamma_dot.shape == (n, 4)
    assert run.platform_attitude.shape == (n, 3, 3) and run.stats["steps"] > 0
    assert run_model(scene, "xmx-2", str(root / "modes"), str(root / "reduction"), str(tmp_path)) == 0
    cli = api.read_simulation(tmp_path / scene / "xmx-2.h5")
    assert cli.model == "xmx-2" and cli.scene == scene
    np.testing.assert_allclose(cli.t, run.t, rtol=0, atol=1e-15)
    # the same computation by two code paths: equal to rounding, far below any model's error
    assert np.all(api.error(cli, run) < 1e-20)
    assert np.max(api.attitude_error_arcsec(cli, run)) < 1e-9
    # the model file the CLI wrote reads back as the same model
    back = api.read_model(tmp_path / "models" / scene / "xmx-2.h5")
    assert back.name == "xmx-2" and back.chain.n_modes == model.chain.n_modes


def test_damping_reaches_the_api_run(files):  # noqa: F811
    """The damped scene's 1 % modal damping is applied to the in-memory model (the CLI applies it
    when it reads the model file): the damped run differs from the undamped one."""
    root, _ = files
    model = api.reduce("freq-2", "thesis", bodies=root / "modes", config=None)
    undamped, damped = api.simulate(model, "thesis"), api.simulate(model, "damped")
    assert np.all(model.chain.bodies[0].damping == 0)
    assert np.max(api.error(undamped, damped)) > 1e-12


def test_reduce_refuses_a_ranked_family_without_its_files(files):  # noqa: F811
    root, _ = files
    with pytest.raises(ValueError, match="reductions: give a folder or 4 paths"):
        api.reduce("xmx-2", "thesis", bodies=root / "modes", reductions=[root / "x.h5"], config=None)

"""The dynamics on the real body files (results/modes, results/reduction); skipped when the
FE and reduction stages have not run."""

import os

import h5py
import numpy as np
import pytest

from gimbal_reduction.solver.dynamics import compiled, dense_baseline, integrators, multibody, scenes, simulate
from gimbal_reduction.reduction import models
from tests.dynamics_fixtures import REAL_MODES as MODES, REAL_REDUCTION as REDUCTION
from tests.dynamics_fixtures import load_real_bodies, real_bodies_only, run_model

pytestmark = real_bodies_only


@pytest.fixture(scope="module")
def real():
    return load_real_bodies()


def test_coupled_frequency_above_kept_frequencies_on_real_bodies(real):
    """The root cause of the freq-10 divergence: the modes carry angular momentum about the
    free drive axes, so the coupled chain's top frequency is well above the kept one."""
    rankings, data = real
    chain = models.build_chain(models.model_spec("freq-10", rankings), data)
    scene = scenes.load_scene("thesis")
    prob = simulate.scene_problem(chain, scene)
    assert prob.omega_max > 2.5 * prob.modal_omega_max
    for b in chain.bodies:
        H = b.momentum[3]
        assert np.max(H ** 2) / b.rigid_mass[3, 3] > 0.8   # one mode ~ a rigid turn about x


def test_freq10_thesis_runs_through_cli(real, tmp_path):
    rc = run_model("thesis", "freq-10", MODES, REDUCTION, str(tmp_path))
    assert rc == 0
    with h5py.File(tmp_path / "thesis" / "freq-10.h5", "r") as f:
        assert np.all(np.isfinite(f["gamma_dot"][()]))
        assert f.attrs["omega_max"] > f.attrs["modal_omega_max"]
        assert f.attrs["integrator"] == "exponential"       # the default (issue 13)
        assert f.attrs["step"] > 100 * f.attrs["stability_limit"]    # not bound by omega_max
        T, W = f["energy/total"][()], f["energy/input_work"][()]
        assert abs(T[-1] - T[0] - W[-1]) < 1e-3 * abs(W[-1])


@pytest.mark.parametrize("args, message", [
    (["--scene", "thesis", "--model", "fraq-10"], "unknown model"),
    (["--scene", "thesis", "--model", "freq-101"], "only 100 computed"),
    (["--scene", "nope", "--model", "freq-10"], "unknown scene"),
    (["--scene", "thesis", "--model", "freq-10", "--integrator", "rk4", "--step", "1e-5"], "stability limit"),
    (["--scene", "thesis", "--model", "freq-10", "--step=-1e-7"], "positive"),
    (["--scene", "thesis", "--model", "truth", "--integrator", "rk4", "--fraction", "1.5"], "stability limit"),
    (["--scene", "thesis", "--model", "freq-10", "--tol", "0"], "positive"),
    (["--scene", "thesis", "--model", "freq-10", "--tol", "1e-5", "--step", "1e-4"], "not both"),
    (["--scene", "thesis", "--model", "freq-10", "--rho-inf", "0.5"], "belongs to generalized-alpha"),
    (["--scene", "thesis", "--model", "freq-10", "--fraction", "0.5"], "belongs to rk4"),
])
def test_bad_input_one_line_on_real_data(real, tmp_path, capsys, args, message):
    scene, model, options = args[1], args[3], args[4:]
    rc = run_model(scene, model, MODES, REDUCTION, str(tmp_path), options)
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not os.path.exists(tmp_path / "thesis")


def test_mass_matrix_columns_agree_with_the_jacobian_assembly_on_the_truth_model(real):
    """Two formulations of M(y): columns of the recursive inverse dynamics (without the
    modal stiffness, whose K q ~ 1e5 |M| would cost digits) and the Jacobian (composite)
    assembly sum J^T N J of the dense baseline.  With K q left in, they differed by 8.7e-12."""
    rankings, data = real
    chain = models.build_chain(models.model_spec("truth", rankings), data)
    n = chain.n_coordinates
    y = np.zeros(n)
    y[:4] = scenes.load_scene("thesis").initial_angles
    y[4:] = 1e-7 * np.random.default_rng(3).normal(size=n - 4)
    M_columns = compiled.FastChain(chain).mass_matrix_by_columns(y)
    M_jacobian = dense_baseline.mass_matrix_composite(dense_baseline.pack_dense(chain), y)
    assert np.abs(M_columns - M_jacobian).max() <= 1e-14 * np.abs(M_jacobian).max()

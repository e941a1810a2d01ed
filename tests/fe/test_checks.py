"""The FE verification checks of verify_fe, run as tests (same functions, same tolerances).

Independent references: the thin-ring formula with its Timoshenko correction,
NAFEMS FV12 (free thin square plate, NAFEMS Selected Benchmarks for Natural
Frequency Analysis, 1987, Test 12), a 3D solid model, mesh refinement, the
discrete Hughes identity, and a second (MPI) run.
"""
import numpy as np
import pytest

from gimbal_reduction.solver.fe import checks as v


def assert_passed(result):
    assert result["passed"], f"{result['name']}: {result['value']:.3g} (tolerance {result['tolerance']:.3g})"


def test_thin_ring_formula_and_timoshenko_estimate(config):
    result = v.check_ring_formula(config)
    assert_passed(result)
    deviations = [m["deviation"] for m in result["modes"]]
    assert deviations[0] < 0 and deviations[0] > deviations[1] > deviations[2]  # grows with n, as predicted


def test_timoshenko_correction_formula():
    # -(1/2) n^2 (t/R)^2 / 12 (1 + 2 (1 + nu) / kappa), by hand for n = 2, t/R = 0.1, nu = 0.3, kappa = 5/6
    assert v.timoshenko_ring_correction(2, 0.1, 0.3, 5 / 6) == pytest.approx(-2 * 0.01 / 12 * (1 + 3.12))


def test_thin_ring_formula_value():
    # omega^2 = E I n^2 (n^2-1)^2 / (rho A R^4 (n^2+1)); n = 2, unit section data: 36 / 5
    f = v.thin_ring_frequency(2, 1.0, 1.0, 12.0, 1.0, 12.0)  # I = 12/12 = 1, rho A = 12 * 12
    assert f == pytest.approx(np.sqrt(36 / 5 / 144) / (2 * np.pi))


def test_nafems_fv12(config):
    assert_passed(v.check_plate_fv12(config, size=0.25))


def test_platform_shell_versus_solid(config):
    assert_passed(v.check_platform_model(config))


@pytest.mark.slow
def test_outer_gimbal_shell_versus_solid(config):
    assert_passed(v.check_solid_ring(config))


def test_shell_versus_solid_coarse(config):
    """The same comparison on a coarser solid (P2 elements through the wall): still within 2 %."""
    import copy

    cfg = copy.deepcopy(config)
    cfg["solid"]["degree"]["value"] = 2
    assert_passed(v.check_solid_ring(cfg, solid_size=0.125, count=6))


def test_mesh_convergence_inner_gimbal(config):
    assert_passed(v.check_convergence(config, 4))


def test_mesh_convergence_reads_level_0_from_the_study_body_file(config, inner_gimbal_file, monkeypatch):
    """The default level's frequencies come from the body file (no solve at its size); they are
    the frequencies a solve of that mesh gives (a fresh solve, to 1e-9 relative)."""
    from gimbal_reduction.solver.fe import checks
    solved, solve = [], checks.supported_frequencies

    def spy(cfg, body, size, count, workdir=None):
        solved.append(size)
        return solve(cfg, body, size, count, workdir)

    monkeypatch.setattr(checks, "supported_frequencies", spy)
    result = v.check_convergence(config, 4, level0=str(inner_gimbal_file[0]))
    assert_passed(result)
    h = result["mesh_sizes"][1]
    assert h not in solved and len(solved) == 2 and result["default_level_from"] == "the study's body file"
    fresh = solve(config, 4, h, 20)
    np.testing.assert_allclose(result["frequencies_hz"][1], fresh, rtol=1e-9)


@pytest.mark.parametrize("change, culprit", [({"body": 3}, "a file of body 3, not of body 4"),
                                             ({"mesh_size": 0.125}, "made at mesh size 0.125 in"),
                                             ({"frequencies_hz": np.ones(5)}, "5 supported frequencies")])
def test_a_wrong_study_body_file_is_refused_before_any_solve(config, inner_gimbal_file, monkeypatch,
                                                             change, culprit):
    from gimbal_reduction.solver.fe import checks
    monkeypatch.setattr(checks, "supported_frequencies", lambda *a, **k: pytest.fail("solved"))
    data = {**checks._body_and_attrs(inner_gimbal_file[0]), **change}
    with pytest.raises(ValueError, match=culprit):
        v.check_convergence(config, 4, level0=data)


@pytest.mark.slow
@pytest.mark.parametrize("body", [2, 3, 5])
def test_mesh_convergence(config, body):
    assert_passed(v.check_convergence(config, body))


def test_body_file_residuals(inner_gimbal_file):
    assert_passed(v.check_body_file(inner_gimbal_file[0]))


def test_body_command_writes_both_parts(inner_gimbal_file, tmp_path):
    """verify body: the body-file check and the spectra of one read, as the two commands."""
    import json

    from gimbal_reduction.solver.fe import verify

    path = str(inner_gimbal_file[0])
    out, spectra = tmp_path / "modes.json", tmp_path / "spectra.json"
    assert verify.main(["body", "--body-file", path, "--out", str(out), "--spectra-out", str(spectra)]) == 0
    assert verify.main(["spectra", "--body-file", path, "--out", str(tmp_path / "alone.json")]) == 0
    modes, both, alone = (json.loads(p.read_text()) for p in (out, spectra, tmp_path / "alone.json"))
    assert modes["passed"] and modes["value"] == v.check_body_file(path)["value"]
    assert both["rigid_modes_found"] == 6
    np.testing.assert_allclose(both["free_free_hz"], alone["free_free_hz"], rtol=1e-12)
    assert verify.main(["body", "--body-file", path, "--out", str(out)]) == 1


@pytest.fixture(scope="module")
def coarse_body_file(tmp_path_factory, config):
    """The coarse inner gimbal (0.75 in, gimbal_reduction.geometry.mesh --coarse) with every finite supported mode,
    through the stage's code (gimbal_reduction.solver.fe.modes --all-modes), as rules coarse_mesh and
    coarse_body_all_modes."""
    from gimbal_reduction.geometry.mesh import mesh_from_config
    from gimbal_reduction.solver.fe import modes

    tmp = tmp_path_factory.mktemp("coarse4")
    mesh_from_config(config, 4, tmp / "body4.msh", 0.75, coarse=True)
    payload = modes.compute_body(4, config, tmp / "body4.msh", log=lambda *a, **k: None, all_modes=True,
                                 mesh_size=0.75)
    modes.write_body_file(tmp / "body4.h5", payload, "test", 0.0)
    return tmp / "body4.h5", payload


def test_hughes_identity(coarse_body_file):
    result = v.check_hughes_identity(coarse_body_file[0])
    assert_passed(result)
    assert result["modes"] == result["finite_modes"] > 2500


def test_hughes_identity_fails_without_a_mode(coarse_body_file, tmp_path):
    """The mode with the least momentum dropped: its contribution is below the tolerance (as for a
    fifth of the coarse body's modes), so the count of the finite modes fails the check."""
    from gimbal_reduction.solver.bodydata import rigid_modes
    from gimbal_reduction.solver.fe import modes

    path, payload = coarse_body_file
    momentum = rigid_modes(payload["dof_coords"], payload["dof_component"]).T @ (payload["M"] @ payload["modes"])
    weakest = int(np.argmin(np.max(np.abs(momentum), axis=0)))
    keep = np.delete(np.arange(payload["modes"].shape[1]), weakest)
    short = {**payload, "modes": payload["modes"][:, keep], "eigenvalues": payload["eigenvalues"][keep],
             "frequencies_hz": payload["frequencies_hz"][keep], "residuals": payload["residuals"][keep],
             "bearing_modes": payload["bearing_modes"][keep]}
    modes.write_body_file(tmp_path / "short.h5", short, "test", 0.0)
    result = v.check_hughes_identity(tmp_path / "short.h5")
    assert not result["passed"] and result["value"] < 1e-8
    assert result["modes"] == result["finite_modes"] - 1


@pytest.mark.mpi
def test_modal_stage_under_mpi(inner_gimbal_file, tmp_path):
    from gimbal_reduction.workflow.config import DEFAULT_CONFIG

    result = v.check_mpi(inner_gimbal_file[0], inner_gimbal_file[1], DEFAULT_CONFIG)
    assert_passed(result)
    assert result["ranks"] == 2


def test_free_free_spectrum_has_six_rigid_modes(inner_gimbal_file):
    spectra = v.body_spectra(inner_gimbal_file[0], 12, 6)
    assert spectra["rigid_modes_found"] == 6
    assert spectra["free_free_hz"][6] > 1e3 * abs(spectra["free_free_hz"][5])


@pytest.mark.slow
def test_connection_study(config):
    result = v.connection_study(config)
    assert_passed(result)
    single = result["drift_between_meshes"]["single mid-width node"]
    assert np.max(np.abs(single)) > np.max(np.abs(result["drift_between_meshes"]["line rigid-fit (default)"]))

"""Bad input gives a one-line ValueError subclass naming the culprit, before expensive work."""

import os
import sys

import h5py
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg

from tests import synthetic_bodies as sb  # noqa: E402

from gimbal_reduction.reduction import modal_integrals as mi  # noqa: E402
from gimbal_reduction.reduction import static_modes as st  # noqa: E402
from gimbal_reduction.reduction import stage  # noqa: E402
from gimbal_reduction.solver.bodydata import read_body_file  # noqa: E402
from gimbal_reduction.reduction.errors import (  # noqa: E402
    BearingIndexError,
    BodyFileError,
    ModeCountError,
    ReductionError,
    SingularStiffnessError,
    UnknownLoadCaseError,
)


def one_line(exc_info):
    message = str(exc_info.value)
    assert "\n" not in message and message
    assert isinstance(exc_info.value, ValueError)
    # body-file errors belong to the contract's owner (gimbal_reduction.solver.bodydata), the rest to the reduction
    assert isinstance(exc_info.value, (ReductionError, BodyFileError))
    return message


@pytest.fixture(scope="module")
def body():
    return sb.ring_body(connection="rods", n_elements=16, n_modes=30)


@pytest.fixture
def no_factorisation(monkeypatch):
    """Fail the test if anything factorises a matrix."""
    def forbidden(*args, **kwargs):
        raise AssertionError("expensive factorisation reached before the input check")
    monkeypatch.setattr(scipy.sparse.linalg, "splu", forbidden)


@pytest.mark.parametrize("name", ["output_motor_fw", "outer_motor_fz", "fz", "", "output_motor_Fz"])
def test_unknown_load_case(name, no_factorisation):
    with pytest.raises(UnknownLoadCaseError) as exc:
        st.parse_load_case(name)
    assert repr(name) in one_line(exc)


def test_unknown_load_case_in_stage_before_work(body, no_factorisation):
    with pytest.raises(UnknownLoadCaseError) as exc:
        stage.reduce_body(dict(body, path="b.h5"), load_cases=["output_motor_fz", "bogus_fz"])
    assert "'bogus_fz'" in one_line(exc)


@pytest.mark.parametrize("bearing", [-1, 4, 7, 1.5])
def test_bearing_index_out_of_range(body, bearing):
    with pytest.raises(BearingIndexError) as exc:
        st.bearing_load(body["bearing_operator"], bearing, np.ones(6))
    assert str(bearing) in one_line(exc)


def test_bearing_index_in_joint_data():
    with pytest.raises(ReductionError) as exc:
        mi.inside_frame_motion(np.zeros((2, 4, 6)), np.ones((4, 3)), motor=5)
    assert "bearing index 5" in one_line(exc)


def test_mode_count_above_computed(body, no_factorisation):
    D = body["modes"].shape[1]
    with pytest.raises(ModeCountError) as exc:
        stage.reduce_body(dict(body, path="b.h5"), n_modes=D + 1)
    assert f"asked for {D + 1}, only {D}" in one_line(exc)
    with pytest.raises(ModeCountError) as exc:
        stage.reduce_body(dict(body, path="b.h5"), n_modes=10, static_kept=11)
    assert "--static-kept" in one_line(exc)
    with pytest.raises(ModeCountError):
        st.check_kept_set(body["modes"], body["eigenvalues"], np.arange(D + 1))
    with pytest.raises(ModeCountError) as exc:
        st.check_kept_set(body["modes"], body["eigenvalues"], [0, D])
    assert str(D) in one_line(exc)


def test_missing_supports_free_body(body, no_factorisation):
    T = sp.identity(body["M"].shape[0], format="csr")
    with pytest.raises(SingularStiffnessError) as exc:
        mi.supported_flexibility(body["K"], T, body["rigid_modes"])
    message = one_line(exc)
    assert "missing supports" in message and "rigid motion" in message


def test_missing_one_support_names_the_motion(body, no_factorisation):
    """Drop the resolver's u_x support: axial translation ux becomes free."""
    n = 16
    motor, resolver = 6 * n, 6 * (n + 1)
    T = sb.selection_basis(body["M"].shape[0], [motor + 1, motor + 2, motor + 3,
                                                resolver + 1, resolver + 2])
    with pytest.raises(SingularStiffnessError) as exc:
        mi.supported_flexibility(body["K"], T, body["rigid_modes"])
    assert "ux" in one_line(exc)


def test_stiffness_without_a_dof(body, no_factorisation):
    """A DOF with no stiffness at all (disconnected) is caught from the diagonal."""
    K = body["K"].tolil()
    K[5, :] = 0.0
    K[:, 5] = 0.0
    with pytest.raises(SingularStiffnessError) as exc:
        mi.supported_flexibility(K.tocsr(), body["T"], body["rigid_modes"])
    assert "zero or negative diagonal" in one_line(exc)


def test_missing_supports_in_stage(body, no_factorisation):
    free = dict(body, T=sp.identity(body["M"].shape[0], format="csr"), path="b.h5")
    # M_inf's solve would factorise first: the stage checks the supports before any of it
    with pytest.raises(SingularStiffnessError):
        stage.reduce_body(free)


# ---------------------------------------------------------------- body files


@pytest.fixture
def body_file(tmp_path, body):
    return sb.write_body_file(tmp_path / "body2.h5", body)


def test_missing_file(tmp_path):
    with pytest.raises(BodyFileError) as exc:
        read_body_file(tmp_path / "nope.h5")
    assert "nope.h5" in one_line(exc)


def test_truncated_file(tmp_path, body_file):
    data = open(body_file, "rb").read()
    bad = tmp_path / "truncated.h5"
    bad.write_bytes(data[: len(data) // 3])
    with pytest.raises(BodyFileError) as exc:
        read_body_file(bad)
    assert "truncated.h5" in one_line(exc)


def test_not_hdf5(tmp_path):
    bad = tmp_path / "garbage.h5"
    bad.write_text("not an hdf5 file\n")
    with pytest.raises(BodyFileError) as exc:
        read_body_file(bad)
    assert "garbage.h5" in one_line(exc)


def test_missing_dataset(body_file):
    with h5py.File(body_file, "a") as f:
        del f["bearing_modes"]
    with pytest.raises(BodyFileError) as exc:
        read_body_file(body_file)
    assert "bearing_modes" in one_line(exc) and "body2.h5" in str(exc.value)


def test_stale_config_hash(body_file):
    with pytest.raises(BodyFileError) as exc:
        read_body_file(body_file, expect_config_hash="abc123")
    assert "stale" in one_line(exc) and "abc123" in str(exc.value)


def test_modes_not_matching_mass(body_file):
    with h5py.File(body_file, "a") as f:
        f["M/data"][...] = 1.01 * f["M/data"][...]
    with pytest.raises(BodyFileError) as exc:
        read_body_file(body_file)
    assert "mass-normalised" in one_line(exc)


def test_shape_mismatch(body_file):
    with h5py.File(body_file, "a") as f:
        lam = f["eigenvalues"][...]
        del f["eigenvalues"]
        f["eigenvalues"] = lam[:-1]
    with pytest.raises(BodyFileError) as exc:
        read_body_file(body_file)
    assert "eigenvalues" in one_line(exc)


def test_cli_error_is_one_line(tmp_path, body_file, capsys):
    code = stage.main(["--body-file", str(body_file), "--out", str(tmp_path / "out.h5"),
                       "--load-cases", "output_motor_fq", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "output_motor_fq" in err
    assert not (tmp_path / "out.h5").exists()

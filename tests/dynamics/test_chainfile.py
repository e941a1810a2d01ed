"""The reduced-model file (gimbal_reduction/solver/dynamics/chainfile.py, docs/models.md): a round trip keeps
every array bit for bit, damping is applied as multibody.make_body applies it, and a bad
file is refused in one line naming the file and the dataset."""
import h5py
import numpy as np
import pytest

from gimbal_reduction.results.bench.oracle import synthetic_chain
from gimbal_reduction.solver.dynamics import chainfile, multibody

FIELDS = ("rigid_mass", "momentum", "inertia_gradient", "coriolis", "omega2", "damping",
          "inside_translation", "inside_rotation")


@pytest.fixture
def written(tmp_path):
    chain, _ = synthetic_chain(seed=3)
    kept = {b.number: np.arange(b.n_modes) for b in chain.bodies}
    static = {b.number: () for b in chain.bodies}
    path = tmp_path / "model.h5"
    chainfile.write_chain(path, chain, kept, static, {"model": "synthetic", "scene": "thesis",
                                                      "config_hash": "abc"})
    return chain, path


def test_round_trip_is_exact(written):
    chain, path = written
    back, info = chainfile.read_chain(path)
    assert info["model"] == "synthetic" and info["config_hash"] == "abc"
    assert back.n_modes == chain.n_modes
    for a, b in zip(chain.bodies, back.bodies):
        for key in FIELDS:
            x, y = getattr(a, key), getattr(b, key)
            assert (x is None) == (y is None), key
            if x is not None:
                assert np.array_equal(x, y), key
    for key in ("gimbal_offset", "case_to_outer", "parent_to_child"):
        assert np.array_equal(getattr(chain, key), getattr(back, key))


def test_damping_is_the_scenes_and_follows_make_body(written):
    _, path = written
    damped, _ = chainfile.read_chain(path, damping_ratio=0.01)
    for body in damped.bodies:
        # independent of the reader: modal damping 2 zeta Omega
        np.testing.assert_allclose(body.damping, 2 * 0.01 * np.sqrt(body.omega2), rtol=1e-15)
    assert isinstance(damped, multibody.Chain)


@pytest.mark.parametrize("damage, message", [
    (lambda f: f.__delitem__("body3/coriolis"), "body3/coriolis"),
    (lambda f: f["body2/omega2"].__setitem__(0, np.nan), "non-finite"),
    (lambda f: f.attrs.__setitem__("format", "something else"), "format"),
    (lambda f: f.__delitem__("chain/gimbal_offset"), "chain/gimbal_offset"),
])
def test_bad_file_is_one_line_naming_the_dataset(written, damage, message):
    _, path = written
    with h5py.File(path, "a") as f:
        damage(f)
    with pytest.raises(chainfile.ChainFileError) as exc:
        chainfile.read_chain(path)
    text = str(exc.value)
    assert "\n" not in text and str(path) in text and message in text


def test_missing_or_garbage_file(tmp_path):
    with pytest.raises(chainfile.ChainFileError, match="not found"):
        chainfile.read_chain(tmp_path / "none.h5")
    garbage = tmp_path / "garbage.h5"
    garbage.write_text("not hdf5\n")
    with pytest.raises(chainfile.ChainFileError, match="corrupt or truncated"):
        chainfile.read_chain(garbage)

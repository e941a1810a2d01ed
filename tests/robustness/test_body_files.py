"""Bad body files (the modal stage's output) given to gimbal_reduction.reduction.models: each refused in one line
naming the file (and the dataset), before any reduction, and no reduced-model file written."""
import h5py
import numpy as np
import pytest

from gimbal_reduction.reduction import models

from .conftest import body_args, reduction_args


def run_args(work, model="xmx-2"):
    return ["--model", model, "--scene", work / "scene.yaml", *body_args(work), *reduction_args(work),
            "--out", work / "out" / "m.h5"]


def rewrite(path, key, change):
    """Replace dataset ``key`` of an HDF5 file by change(its value)."""
    with h5py.File(path, "r+") as f:
        value = f[key][()]
        del f[key]
        new = change(np.array(value))
        if new is not None:
            f[key] = new


def swap_modes(v):
    v[:, [0, 1]] = v[:, [1, 0]]
    return v


def scaled_column(v):
    v[:, 2] *= 1.001
    return v


def one_entry(v):
    i = np.argmax(np.abs(v[:, 3]))
    v[i, 3] *= 1.02
    return v


def nan_at(index):
    def change(v):
        v = v.astype(float)
        v[index] = np.nan
        return v
    return change


CASES = {
    # name: (dataset, change, words of the message)
    "nan eigenvalue (was sorted last)": ("eigenvalues", nan_at(1), ("eigenvalues", "finite")),
    "negative eigenvalue": ("eigenvalues", lambda v: v * np.r_[-1, np.ones(v.size - 1)],
                            ("eigenvalues", "positive")),
    "eigenvalues not ascending": ("eigenvalues", lambda v: v[[1, 0, *range(2, v.size)]],
                                  ("eigenvalues", "ascending")),
    "eigenvalue 1 % off": ("eigenvalues", lambda v: v * np.r_[1, 1.01, np.ones(v.size - 2)],
                           ("frequencies_hz",)),
    "frequencies garbage": ("frequencies_hz", lambda v: v * 7, ("frequencies_hz",)),
    "modes column scaled 0.1 %": ("modes", scaled_column, ("modes", "mass-normalised")),
    "modes one entry 2 % off": ("modes", one_entry, ("modes",)),
    "modes swapped columns": ("modes", swap_modes, ("eigenvalues and modes disagree",)),
    "modes nan": ("modes", nan_at((0, 0)), ("modes", "non-finite")),
    "modes a column dropped": ("modes", lambda v: v[:, :-1], ("has shape",)),
    "modes transposed": ("modes", lambda v: v.T.copy(), ("has shape",)),
    "dof_coords inf": ("dof_coords", lambda v: np.where(np.arange(v.size).reshape(v.shape) == 0,
                                                        np.inf, v), ("dof_coords",)),
    "rigid_modes changed": ("rigid_modes", lambda v: v * 1.5, ("rigid_modes",)),
    "bearing_modes wrong shape": ("bearing_modes", lambda v: v[:, :3], ("bearing_modes", "shape")),
    "dof_component out of range": ("dof_component", lambda v: v + 7, ("dof_component",)),
    "M data nan": ("M/data", nan_at(0), ("M",)),
    "eigenvalues missing": ("eigenvalues", lambda v: None, ("eigenvalues", "missing")),
    "modes missing": ("modes", lambda v: None, ("modes", "missing")),
    "K data missing": ("K/data", lambda v: None, ("K",)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_corrupt_body_dataset(case, work, refused):
    key, change, words = CASES[case]
    path = work / "modes" / "body3.h5"
    rewrite(path, key, change)
    refused(models.main, run_args(work), (str(path), *words), work / "out", work / "modes")


def test_eigenvalue_with_consistent_frequency_caught_by_eigenpairs(work, refused):
    path = work / "modes" / "body3.h5"
    rewrite(path, "eigenvalues", lambda v: v * np.r_[1, 1.01, np.ones(v.size - 2)])
    rewrite(path, "frequencies_hz", lambda v: v * np.r_[1, np.sqrt(1.01), np.ones(v.size - 2)])
    refused(models.main, run_args(work), (str(path), "eigenvalues and modes disagree"),
            work / "out", work / "modes")


def test_missing_body_file(work, refused):
    path = work / "modes" / "body4.h5"
    path.unlink()
    refused(models.main, run_args(work), (str(path), "not found", "snakemake"), work / "out")


def test_zero_byte_body_file(work, refused):
    path = work / "modes" / "body2.h5"
    path.write_bytes(b"")
    refused(models.main, run_args(work), (str(path), "HDF5"), work / "out", work / "modes")


def test_truncated_body_file(work, refused):
    path = work / "modes" / "body5.h5"
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    refused(models.main, run_args(work), (str(path),), work / "out", work / "modes")


def test_text_file_as_body_file(work, refused):
    path = work / "modes" / "body2.h5"
    path.write_text("frequencies: 1 2 3\n")
    refused(models.main, run_args(work), (str(path), "HDF5"), work / "out", work / "modes")


def test_garbage_in_the_middle_of_a_body_file(work, refused):
    path = work / "modes" / "body2.h5"
    data = bytearray(path.read_bytes())
    data[:512] = bytes(512)                   # the superblock overwritten
    path.write_bytes(bytes(data))
    refused(models.main, run_args(work), (str(path),), work / "out", work / "modes")


def test_body_file_of_another_config_refused_with_config(work, refused):
    """A body file relabelled as made from another configuration: against the project config it
    is refused; the message names the file and the target."""
    import h5py
    from gimbal_reduction.workflow.config import DEFAULT_CONFIG
    path = work / "modes" / "body2.h5"
    with h5py.File(path, "r+") as f:
        f.attrs["config_hash"] = "0123456789ab"
    refused(models.main, run_args(work) + ["--config", DEFAULT_CONFIG],
            (str(path), "another configuration", "snakemake"), work / "out", work / "modes")


def test_body_file_of_the_current_config_accepted(work, capsys):
    """The control: body files whose config_hash is the current configuration's pass."""
    from gimbal_reduction.workflow import config as cfgmod
    for b in models.BODIES:
        with h5py.File(work / "modes" / f"body{b}.h5", "r+") as f:
            f.attrs["config_hash"] = models.expected_body_hashes(cfgmod.load_config())[b]
        with h5py.File(work / "reduction" / f"body{b}.h5", "r+") as f:
            f.attrs["config_hash"] = models.expected_body_hashes(cfgmod.load_config())[b]
    assert models.main([str(a) for a in run_args(work) + ["--config", cfgmod.DEFAULT_CONFIG]]) == 0
    assert (work / "out" / "m.h5").exists()

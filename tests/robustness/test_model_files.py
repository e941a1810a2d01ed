"""Bad reduced-model files given to simulate: refused in one line naming the file and the
dataset before the integration, no simulation file written."""
import h5py
import numpy as np
import pytest

from gimbal_reduction.solver.dynamics import simulate

MODEL = ("models", "scene", "xmx-2.h5")


def sim_args(work, extra=()):
    return ["--scene", work / "scene.yaml", "--model-file", work.joinpath(*MODEL),
            "--out", work / "out" / "s.h5", *extra]


def change(path, key, fn):
    with h5py.File(path, "r+") as f:
        value = f[key][()]
        del f[key]
        new = fn(np.array(value))
        if new is not None:
            f[key] = new


CASES = {
    "omega2 missing": ("body3/omega2", lambda v: None, ("omega2", "missing")),
    "momentum nan": ("body2/momentum", lambda v: np.full_like(v, np.nan), ("momentum",)),
    "omega2 negative": ("body4/omega2", lambda v: -v, ("omega2",)),
    "coriolis wrong shape": ("body2/coriolis", lambda v: v[:1], ("coriolis",)),
    "rigid_mass wrong shape": ("body5/rigid_mass", lambda v: v[:3], ("rigid_mass",)),
    "gimbal_offset missing": ("chain/gimbal_offset", lambda v: None, ("gimbal_offset", "missing")),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_corrupt_model_dataset(case, work, refused):
    key, fn, words = CASES[case]
    path = work.joinpath(*MODEL)
    change(path, key, fn)
    refused(simulate.main, sim_args(work), (str(path), *words), work / "out", work / "models")


def test_missing_model_file(work, refused):
    path = work.joinpath(*MODEL)
    path.unlink()
    refused(simulate.main, sim_args(work), (str(path), "not found"), work / "out")


def test_zero_byte_model_file(work, refused):
    path = work.joinpath(*MODEL)
    path.write_bytes(b"")
    refused(simulate.main, sim_args(work), (str(path), "HDF5"), work / "out", work / "models")


def test_truncated_model_file(work, refused):
    path = work.joinpath(*MODEL)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 3])
    refused(simulate.main, sim_args(work), (str(path),), work / "out", work / "models")


def test_body_file_given_as_model_file(work, refused):
    body = work / "modes" / "body2.h5"
    refused(simulate.main, ["--scene", work / "scene.yaml", "--model-file", body,
                            "--out", work / "out" / "s.h5"], (str(body), "format"), work / "out")


def test_model_file_of_other_body_files_refused_with_config(work, refused):
    """A reduced model made from body files of another configuration: against the project config
    it is stale: the message names the file and the targets to rerun."""
    import json
    from gimbal_reduction.workflow.config import DEFAULT_CONFIG
    path = work.joinpath(*MODEL)
    with h5py.File(path, "r+") as f:
        f.attrs["body_config_hashes"] = json.dumps(["0123456789ab"] * 4)
    refused(simulate.main, sim_args(work, ["--config", DEFAULT_CONFIG]),
            (str(path), "another configuration", "results/modes/body2.h5"), work / "out")


def test_model_file_without_body_hashes_refused_with_config(work, refused):
    from gimbal_reduction.workflow.config import DEFAULT_CONFIG
    path = work.joinpath(*MODEL)
    with h5py.File(path, "r+") as f:
        del f.attrs["body_config_hashes"]
    refused(simulate.main, sim_args(work, ["--config", DEFAULT_CONFIG]),
            (str(path), "body_config_hashes"), work / "out", work / "models")


def test_model_name_mismatch(work, refused):
    refused(simulate.main, ["--scene", work / "scene.yaml", "--model-file", work.joinpath(*MODEL),
                            "--model", "freq-2", "--out", work / "out" / "s.h5"],
            ("xmx-2", "freq-2"), work / "out")

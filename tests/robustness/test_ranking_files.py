"""Bad reduction (ranking) files and load-aware ranking files given to gimbal_reduction.reduction.models: refused
in one line naming the file and the dataset, no reduced-model file written."""
import h5py
import numpy as np
import pytest

from gimbal_reduction.reduction import models

from .conftest import body_args, reduction_args


def run_args(work, model="xmx-2", extra=()):
    return ["--model", model, "--scene", work / "scene.yaml", *body_args(work), *reduction_args(work),
            *extra, "--out", work / "out" / "m.h5"]


def set_dataset(path, key, value):
    with h5py.File(path, "r+") as f:
        if key in f:
            del f[key]
        if value is not None:
            f[key] = value


CASES = {
    "rank_xmx missing": ("rank_xmx", None, ("rank_xmx", "missing")),
    "rank_xmx repeats a mode": ("rank_xmx", np.array([3, 1, 1, 2, 5, 4]), ("rank_xmx", "permutation")),
    "rank_xmx index out of range": ("rank_xmx", np.array([3, 1, 0, 2, 5, 9]), ("rank_xmx", "permutation")),
    "rank_xmx negative index": ("rank_xmx", np.array([3, 1, 0, 2, 5, -1]), ("rank_xmx", "permutation")),
    "rank_xmx too short": ("rank_xmx", np.array([3, 1, 0, 2, 4]), ("rank_xmx",)),
    "rank_xmgmx nan": ("rank_xmgmx", np.array([3, 1, np.nan, 2, 4, 5]), ("rank_xmgmx",)),
    "rank_xmx 2-D": ("rank_xmx", np.arange(6).reshape(2, 3), ("rank_xmx",)),
    "rank_frequency too long": ("rank_frequency", np.arange(7), ("rank_frequency",)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_corrupt_ranking_dataset(case, work, refused):
    key, value, words = CASES[case]
    path = work / "reduction" / "body4.h5"
    set_dataset(path, key, value)
    refused(models.main, run_args(work), (str(path), *words), work / "out", work / "reduction")


def test_missing_reduction_file(work, refused):
    path = work / "reduction" / "body3.h5"
    path.unlink()
    refused(models.main, run_args(work), (str(path), "missing"), work / "out")


def test_text_file_as_reduction_file(work, refused):
    path = work / "reduction" / "body3.h5"
    path.write_text("rank_xmx: 3 1 0 2 5 4\n")
    refused(models.main, run_args(work), (str(path), "HDF5"), work / "out", work / "reduction")


def test_zero_byte_reduction_file(work, refused):
    path = work / "reduction" / "body2.h5"
    path.write_bytes(b"")
    refused(models.main, run_args(work), (str(path), "HDF5"), work / "out", work / "reduction")


def test_reduction_file_of_another_body_file(work, refused):
    path = work / "reduction" / "body5.h5"
    with h5py.File(path, "r+") as f:
        f.attrs["config_hash"] = "0123456789ab"
    refused(models.main, run_args(work), (str(path), "another body file"), work / "out",
            work / "reduction")


def test_load_ranking_missing(work, refused):
    path = work / "reduction" / "load.h5"
    refused(models.main, run_args(work, "load-2", ["--load-ranking", path]), (str(path), "missing"),
            work / "out")


def test_load_ranking_text_file(work, refused):
    path = work / "reduction" / "load.h5"
    path.write_text("not hdf5")
    refused(models.main, run_args(work, "load-2", ["--load-ranking", path]), (str(path),),
            work / "out", work / "reduction")


def test_load_ranking_without_pooled(work, refused):
    path = work / "reduction" / "load.h5"
    with h5py.File(path, "w") as f:
        for b in models.BODIES:
            f[f"body{b}/rank_load"] = np.arange(6)
    refused(models.main, run_args(work, "load-2", ["--load-ranking", path]), (str(path), "pooled"),
            work / "out", work / "reduction")


def test_load_ranking_not_given(work, refused):
    refused(models.main, run_args(work, "global-8"), ("global-8", "--load-ranking"), work / "out")


def write_load_ranking(path, scene_path, loads_hash=True):
    """A small, valid load-aware ranking file made for the scene at ``scene_path`` (with the loads
    hash the ranking stage writes, or, as an older file, with the whole scene's hash only)."""
    from gimbal_reduction.solver.dynamics import scenes
    with h5py.File(path, "w") as f:
        for b in models.BODIES:
            f[f"body{b}/rank_load"] = np.arange(6)
        f["pooled/body"] = np.repeat(np.array(models.BODIES), 6)
        f["pooled/mode"] = np.tile(np.arange(6), len(models.BODIES))
        scene = scenes.load_scene(str(scene_path))
        f.attrs["scene"], f.attrs["scene_hash"] = scene.name, scene.config_hash()
        if loads_hash:
            f.attrs["scene_loads_hash"] = scene.loads_hash()
    return path


@pytest.mark.parametrize("loads_hash", [True, False])
def test_a_ranking_made_for_another_scene_is_refused(work, refused, loads_hash):
    """The ranking's scene (its loads) must be the scene being reduced: a ranking of the scene's
    own is accepted, the same file made for another scene (thesis: 15 ms, not 1 ms) is refused in
    one line naming the file and both scenes."""
    path = write_load_ranking(work / "reduction" / "load.h5", work / "scene.yaml", loads_hash)
    assert models.main([str(a) for a in run_args(work, "load-2", ["--load-ranking", path])]) == 0
    (work / "out" / "m.h5").unlink()
    write_load_ranking(path, models.scenes.SCENES_DIR + "/thesis.yaml", loads_hash)
    refused(models.main, run_args(work, "load-2", ["--load-ranking", path]),
            (str(path), "made for scene 'thesis'", "scene 'scene'"), work / "out")


def test_a_body_file_in_another_bodys_slot_is_refused(work, refused):
    """body 3's file given as body 4's: refused by the file's own body number, no config needed."""
    args = run_args(work)
    i = args.index("--bodies")
    args[i + 3] = args[i + 2]          # body 3's file in body 4's place
    refused(models.main, args, (str(args[i + 2]), "body 3", "body 4's"), work / "out")

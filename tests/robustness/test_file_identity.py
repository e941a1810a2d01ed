"""Files that are not what their reader expects: refused in one line naming the file, always (no
flag to remember), before the work, nothing written.

* identity: a model file copied over another model's target, or made for another scene than its
  folder's (simulate, ``check_identity``); a body file in another body's slot is
  test_ranking_files.py's case, a ranking of another scene too;
* content: a number changed after the file was written (``content_hashes``, checked by every
  reader of an HDF5 file the project writes), named by file and dataset;
* provenance: the configuration in use is the default ``--config`` (test_config_hashes.py)."""
import shutil

import h5py
import numpy as np
import pytest

from gimbal_reduction.reduction import models
from gimbal_reduction.solver.dynamics import simfile, simulate
from gimbal_reduction.solver.dynamics.error_measure import ErrorsInputError
from gimbal_reduction.workflow import provenance

from .conftest import body_args, reduction_args

MODEL = ("models", "scene", "xmx-2.h5")


def scale(path, key, factor):
    """Multiply dataset ``key`` of an HDF5 file in place (as a user editing a number would)."""
    with h5py.File(path, "r+") as f:
        f[key][...] = f[key][()] * factor


def test_a_model_file_copied_over_another_models_target_is_refused(work, refused):
    """xmx-2's file copied over freq-2.h5: the workflow's simulate (model file and output of one
    name) refuses it by the model the file holds, without --model."""
    target = work / "models" / "scene" / "freq-2.h5"
    shutil.copy(work.joinpath(*MODEL), target)
    refused(simulate.main, ["--scene", work / "scene.yaml", "--model-file", target,
                            "--out", work / "out" / "freq-2.h5"],
            (str(target), "holds model 'xmx-2', not 'freq-2'", "--forcerun"), work / "out")


def test_a_model_file_of_another_scene_in_this_scenes_folder_is_refused(work, refused):
    path = work.joinpath(*MODEL)
    with h5py.File(path, "r+") as f:
        f.attrs["scene"] = "thesis"
    refused(simulate.main, ["--scene", work / "scene.yaml", "--model-file", path,
                            "--out", work / "out" / "xmx-2.h5"],
            (str(path), "made for scene 'thesis', not 'scene'"), work / "out")


def test_a_model_file_under_another_name_is_simulated(work):
    """The control: a model file named freely (outside the workflow's layout) is the user's choice."""
    other = work / "mine.h5"
    shutil.copy(work.joinpath(*MODEL), other)
    assert simulate.main([str(a) for a in ["--scene", work / "scene.yaml", "--model-file", other,
                                           "--out", work / "out" / "s.h5"]]) == 0


@pytest.mark.parametrize("key, factor", [("body4/momentum", 1.05), ("body2/omega2", 0.99),
                                         ("chain/gimbal_offset", 2.0)])
def test_a_changed_number_in_a_model_file_is_refused(key, factor, work, refused):
    path = work.joinpath(*MODEL)
    scale(path, key, factor)
    refused(simulate.main, ["--scene", work / "scene.yaml", "--model-file", path,
                            "--out", work / "out" / "s.h5"], (str(path), f"'{key}'", "changed"),
            work / "out")


def write_hashed_ranking(path, scene_path, estimate):
    """A load-aware ranking written as the ranking stage writes (``atomic_h5``: with content hashes)."""
    from gimbal_reduction.solver.dynamics import scenes
    scene = scenes.load_scene(str(scene_path))
    with provenance.atomic_h5(path) as f:
        for b in models.BODIES:
            f[f"body{b}/rank_load"] = np.arange(6)
        f["pooled/body"] = np.repeat(np.array(models.BODIES), 6)
        f["pooled/mode"] = np.tile(np.arange(6), len(models.BODIES))
        f["estimate/global"] = estimate
        f["estimate/rigid"] = np.full(4, 1.0)
        f.attrs["scene"], f.attrs["scene_hash"] = scene.name, scene.config_hash()
        f.attrs["scene_loads_hash"] = scene.loads_hash()
    return path


def ranking_args(work, model, ranking):
    return ["--model", model, "--scene", work / "scene.yaml", *body_args(work), *reduction_args(work),
            "--load-ranking", ranking, "--no-verified-search", "--out", work / "out" / "m.h5"]


def test_a_changed_estimate_in_a_ranking_file_is_refused(work, refused):
    """estimate/global set to 1e-12 would make tol-1e-4 pick one mode: refused by its content hash."""
    estimate = np.geomspace(1.0, 1e-6, 24)[:, None] * np.ones(4)
    path = write_hashed_ranking(work / "reduction" / "load.h5", work / "scene.yaml", estimate)
    with h5py.File(path, "r+") as f:
        f["estimate/global"][...] = 1e-12
    refused(models.main, ranking_args(work, "tol-1e-4", path),
            (str(path), "'estimate/global'", "changed"), work / "out")


def test_nan_in_a_rankings_estimates_is_refused(work, refused):
    """A NaN estimate, written as such (the hash agrees): refused by the reader, naming the dataset."""
    estimate = np.geomspace(1.0, 1e-6, 24)[:, None] * np.ones(4)
    estimate[3, 1] = np.nan
    path = write_hashed_ranking(work / "reduction" / "load.h5", work / "scene.yaml", estimate)
    refused(models.main, ranking_args(work, "tol-1e-4", path),
            (str(path), "estimate/global", "NaN"), work / "out")


def test_a_changed_number_in_a_simulation_file_is_refused(work):
    out = work / "out" / "s.h5"
    assert simulate.main([str(a) for a in ["--scene", work / "scene.yaml", "--model-file",
                                           work.joinpath(*MODEL), "--out", out]]) == 0
    simfile.read_sim(out)                                   # as written: read
    scale(out, "gamma_dot", 1.001)
    with pytest.raises(ErrorsInputError, match="'gamma_dot' was changed") as exc:
        simfile.read_sim(out)
    assert str(out) in str(exc.value) and "\n" not in str(exc.value)


def test_a_changed_number_in_a_body_file_is_refused(work, refused):
    """A body file as the modal stage writes it (atomic_h5), a bearing position edited: the reduced-model
    stage names the file and the dataset (an edit the contract's own checks cannot see)."""
    path = work / "modes" / "body3.h5"
    with h5py.File(path, "r") as src, provenance.atomic_h5(path.with_suffix(".new")) as dst:
        for key, value in src.attrs.items():
            dst.attrs[key] = value
        for name in src:
            src.copy(src[name], dst, name)
    path.with_suffix(".new").replace(path)
    assert models.main([str(a) for a in ["--model", "freq-2", "--scene", work / "scene.yaml",
                                         *body_args(work), "--out", work / "out" / "ok.h5"]]) == 0
    (work / "out" / "ok.h5").unlink()
    scale(path, "bearing_points", 1.0001)
    refused(models.main, ["--model", "freq-2", "--scene", work / "scene.yaml", *body_args(work),
                          "--out", work / "out" / "m.h5"], (str(path), "'bearing_points'", "changed"),
            work / "out")


def test_content_hashes_cover_every_numeric_dataset_and_no_string(tmp_path):
    path = tmp_path / "f.h5"
    with provenance.atomic_h5(path) as f:
        f["a/x"] = np.arange(3.0)
        f["n"] = np.int64(4)
        f["labels"] = np.array(["mode 0"], dtype=h5py.string_dtype())
    with h5py.File(path, "r") as f:
        assert sorted(provenance.content_hashes(f)) == ["a/x", "n"]
        assert provenance.content_problem(f, path) is None
    # the digest sees dtype and shape, not only the bytes
    assert provenance.dataset_digest(np.zeros(4)) != provenance.dataset_digest(np.zeros((2, 2)))
    assert provenance.dataset_digest(np.zeros(2, np.float64)) != provenance.dataset_digest(np.zeros(4, np.float32))


@pytest.mark.parametrize("kind", ["bodies", "reductions"])
def test_a_file_in_another_bodys_slot_is_refused_by_the_load_ranking(kind, work, refused):
    """body 3's (body or reduction) file given as body 4's to the load-aware ranking: refused by its
    own body number before the work, with no configuration needed."""
    from gimbal_reduction.reduction import load_aware
    args = ["--scene", work / "scene.yaml", *body_args(work), *reduction_args(work),
            "--out", work / "out" / "l.h5"]
    i = args.index(f"--{kind}")
    args[i + 3] = args[i + 2]
    refused(load_aware.main, args, (str(args[i + 2]), "body 3", "body 4's"), work / "out")


def test_a_reduction_file_in_another_bodys_slot_is_refused_by_the_model_stage(work, refused):
    args = ["--model", "xmx-2", "--scene", work / "scene.yaml", *body_args(work), *reduction_args(work),
            "--out", work / "out" / "m.h5"]
    i = args.index("--reductions")
    args[i + 1], args[i + 2] = args[i + 2], args[i + 1]
    refused(models.main, args, (str(args[i + 1]), "body 3", "body 2's"), work / "out")


def test_a_verified_file_is_hashed_once_and_a_rewritten_one_again(tmp_path, monkeypatch):
    """content_problem remembers a settled file it found intact (VerifiedContent: the study's loop
    reads the same files for every model), and still names a number changed since: the write gives
    the file a new mtime.  A file written within the last second is not remembered (a coarse
    file-system clock could give a quick rewrite the same mtime)."""
    import os
    import time
    path = tmp_path / "f.h5"
    with provenance.atomic_h5(path) as f:
        f["x"] = np.arange(4.0)
    settled = time.time_ns() - 10 * provenance.VerifiedContent.SETTLED_NS
    os.utime(path, ns=(settled, settled))
    calls = []
    digest = provenance.dataset_digest
    monkeypatch.setattr(provenance, "dataset_digest", lambda v: calls.append(1) or digest(v))
    for _ in range(3):
        with h5py.File(path, "r") as f:
            assert provenance.content_problem(f, path) is None
    assert len(calls) == 1                                   # hashed once, then remembered
    scale(path, "x", 2.0)                                    # same size, a new mtime
    with h5py.File(path, "r") as f:
        assert "'x' was changed" in provenance.content_problem(f, path)
    fresh = tmp_path / "g.h5"                                # written just now: not remembered
    with provenance.atomic_h5(fresh) as f:
        f["x"] = np.arange(4.0)
    calls.clear()
    for _ in range(2):
        with h5py.File(fresh, "r") as f:
            assert provenance.content_problem(f, fresh) is None
    assert len(calls) == 2

"""Several reduced models in one call of gimbal_reduction.reduction.models (the workflow's
bench_models.smk, rule plain_models): each file the one a single call makes, and a bad request refused in one line
before any file is written."""
import h5py
import numpy as np

from gimbal_reduction.reduction import models

from .conftest import body_args, reduction_args, write_scene


def datasets(path):
    """{name: array} of every dataset of an HDF5 file."""
    out = {}
    with h5py.File(path) as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset)
                     else None)
    return out


def test_model_jobs_pairs_one_value_with_every_file():
    assert models.model_jobs(["truth"], ["a", "b"], ["a.h5", "b.h5"]) == \
        [("truth", "a", "a.h5"), ("truth", "b", "b.h5")]
    assert models.model_jobs(["freq-2", "xmx-2"], ["s"], ["f.h5", "x.h5"]) == \
        [("freq-2", "s", "f.h5"), ("xmx-2", "s", "x.h5")]


def test_several_models_in_one_call_are_the_single_calls_files(work):
    """Two scenes and two models: every file holds what its own call writes (every dataset to
    1e-12 of its scale; the model and the scene it names)."""
    other = write_scene(work / "other.yaml")
    common = [*body_args(work), *reduction_args(work)]
    pairs = [("xmx-2", work / "scene.yaml"), ("freq-3", other)]
    together = [work / "out" / f"together{k}.h5" for k in range(2)]
    assert models.main(["--model", *[m for m, _ in pairs], "--scene", *[str(s) for _, s in pairs],
                        *common, "--out", *map(str, together)]) == 0
    for (model, scene), path in zip(pairs, together):
        alone = work / "out" / f"alone-{model}.h5"
        assert models.main(["--model", model, "--scene", str(scene), *common, "--out", str(alone)]) == 0
        a, b = datasets(alone), datasets(path)
        assert a.keys() == b.keys() and a
        for name in a:
            if np.asarray(a[name]).dtype.kind not in "fc":
                assert np.array_equal(a[name], b[name]), name
                continue
            scale = max(float(np.max(np.abs(a[name]), initial=0.0)), 1e-300)
            assert a[name].shape == b[name].shape
            assert np.max(np.abs(a[name] - b[name]), initial=0.0) <= 1e-12 * scale, name
        with h5py.File(path) as f:
            assert f.attrs["model"] == model and f.attrs["scene"] == scene.stem


def test_counts_that_do_not_pair_are_refused(work, refused):
    argv = ["--model", "xmx-2", "freq-2", "freq-3", "--scene", work / "scene.yaml", *body_args(work),
            *reduction_args(work), "--out", work / "out" / "a.h5", work / "out" / "b.h5"]
    refused(models.main, argv, ("--model gives 3 values for 2 --out",), work / "out")


def test_a_file_named_twice_is_refused(work, refused):
    out = work / "out" / "a.h5"
    argv = ["--model", "xmx-2", "freq-2", "--scene", work / "scene.yaml", *body_args(work),
            *reduction_args(work), "--out", out, out]
    refused(models.main, argv, (str(out), "more than once"), work / "out")


def test_a_bad_last_model_writes_no_file(work, refused):
    """The last model asks for more modes than the body files hold: refused, and the good first
    model's file is not written either."""
    argv = ["--model", "xmx-2", "freq-10", "--scene", work / "scene.yaml", *body_args(work),
            *reduction_args(work), "--out", work / "out" / "a.h5", work / "out" / "b.h5"]
    refused(models.main, argv, ("freq-10", "only 6 computed"), work / "out")

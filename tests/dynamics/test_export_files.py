"""The export's files (gimbal_reduction.solver.dynamics.export): the .mat and the .npz written beside each other
atomically (no temporary file left, exact names), and --config refusing a reduced model made from
body files of another configuration in one line, on a small synthetic chain."""
import json
import os

import numpy as np
import scipy.io

from gimbal_reduction.solver.dynamics import chainfile, export
from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain
from gimbal_reduction.workflow.provenance import read_provenance
from tests.reduction.test_models import project_model_attrs

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def model_file(path, body_hashes=None):
    """A synthetic reduced-model file made from body files with ``body_hashes`` (default: the
    project configuration's, which the export checks against when no --config is given)."""
    body_hashes = body_hashes or json.loads(project_model_attrs()["body_config_hashes"])
    chain = synthetic_modal_chain(2, seed=5)
    chainfile.write_chain(path, chain, {b.number: np.arange(b.n_modes) for b in chain.bodies},
                          {b.number: () for b in chain.bodies},
                          {"model": "freq-2", "scene": "thesis", "config_hash": "c0ffee",
                           "body_config_hashes": json.dumps(body_hashes)})
    return str(path)


def test_mat_and_npz_are_written_beside_each_other(tmp_path):
    model = model_file(tmp_path / "model.h5")
    out = tmp_path / "export" / "thesis" / "freq-2.mat"
    assert export.main(["--model-file", model, "--scene", "thesis", "--out", str(out)]) == 0
    assert sorted(os.listdir(out.parent)) == ["freq-2.mat", "freq-2.npz"]       # nothing else left
    mat, npz = scipy.io.loadmat(out), np.load(out.with_suffix(".npz"))
    n = 4 + 4 * 2
    assert mat["A"].shape == (2 * n, 2 * n) and np.array_equal(mat["A"], npz["A"])
    assert np.array_equal(mat["A"][:n, n:], np.eye(n)) and mat["B"].shape == (2 * n, 7)
    for path in (out, out.with_suffix(".npz")):                                  # the model file's hash
        assert read_provenance(path)["config_hash"] == "c0ffee"


def test_config_check_refuses_a_model_of_other_body_files(tmp_path, capsys):
    model = model_file(tmp_path / "model.h5", ["a", "b", "c", "d"])
    out = tmp_path / "x.mat"
    code = export.main(["--model-file", model, "--scene", "thesis", "--out", str(out),
                        "--config", os.path.join(ROOT, "config", "config.yaml")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and model in err and "another configuration" in err
    assert not out.exists() and not out.with_suffix(".npz").exists()


def test_an_extension_the_export_does_not_write_is_refused_before_the_work(tmp_path, capsys):
    model = model_file(tmp_path / "model.h5")
    for out in (tmp_path / "model_ss.h5", tmp_path / "model_ss"):
        code = export.main(["--model-file", model, "--scene", "no_such_scene", "--out", str(out)])
        err = capsys.readouterr().err.strip()
        # the extension is named first: the scene (which would fail later) is never read
        assert code == 2 and len(err.splitlines()) == 1 and str(out) in err and ".mat and .npz" in err, err
    assert sorted(os.listdir(tmp_path)) == ["model.h5"]


def test_a_pair_that_cannot_be_written_whole_leaves_neither_file(tmp_path, capsys, monkeypatch):
    """The .npz's write fails (a full disk, simulated): no .mat is left behind, and the message
    names the .npz."""
    model = model_file(tmp_path / "model.h5")
    out = tmp_path / "export" / "freq-2.mat"

    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(export.np, "savez_compressed", full_disk)
    assert export.main(["--model-file", model, "--scene", "thesis", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "freq-2.npz" in err and "no space left" in err, err
    assert not out.parent.exists() or os.listdir(out.parent) == []

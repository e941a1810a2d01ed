"""The simulate CLI takes its output path from the caller (the DAG), never from a field
inside the scene file: a scene copied from thesis.yaml with its name: left in it is refused
before any work, and a renamed copy writes exactly where it is told."""
import os

import h5py
import numpy as np
import pytest
import yaml

from results.bench.oracle import synthetic_chain
from solver.dynamics import chainfile, scenes, simulate


@pytest.fixture
def model_file(tmp_path):
    chain, _ = synthetic_chain(seed=1)
    path = tmp_path / "models" / "m.h5"
    chainfile.write_chain(path, chain, {b.number: np.arange(b.n_modes) for b in chain.bodies},
                          {b.number: () for b in chain.bodies}, {"model": "freq-2", "config_hash": "x"})
    return path


def copied_scene(tmp_path, stem, name):
    raw = yaml.safe_load(open(os.path.join(scenes.SCENES_DIR, "thesis.yaml")))
    raw["name"] = name
    raw["duration"]["value"] = 1e-3
    path = tmp_path / f"{stem}.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def test_copied_scene_with_the_old_name_is_refused(tmp_path, model_file, capsys):
    scene = copied_scene(tmp_path, "thesis_copy", "thesis")
    out = tmp_path / "sim" / "thesis_copy" / "freq-2.h5"
    rc = simulate.main(["--scene", str(scene), "--model-file", str(model_file), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "thesis_copy" in err[0] and "name" in err[0]
    assert not (tmp_path / "sim").exists()


def test_output_goes_where_the_caller_says(tmp_path, model_file):
    scene = copied_scene(tmp_path, "thesis_copy", "thesis_copy")
    out = tmp_path / "elsewhere" / "run.h5"
    assert simulate.main(["--scene", str(scene), "--model-file", str(model_file), "--out", str(out)]) == 0
    with h5py.File(out, "r") as f:
        assert f.attrs["scene"] == "thesis_copy" and f.attrs["model"] == "freq-2"
        assert f["gamma_dot"].shape == (101, 4) and np.all(np.isfinite(f["gamma_dot"][()]))
    assert sorted(os.listdir(tmp_path / "elsewhere")) == ["run.h5"]

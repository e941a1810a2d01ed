"""Shared fixtures of the robustness suite (issue 15): small synthetic inputs of every stage and
the one assertion every case makes.

Every case calls a command line's ``main(argv)`` in process with one bad input and asserts
``refused``: a non-zero status, exactly one line on stderr naming the culprit, and no file
added, changed or removed in the folders it watches (the output folder and the inputs).
The inputs are tiny (four synthetic bodies of 6 modes, a 1 ms scene), so the suite runs in
well under a minute."""
from __future__ import annotations

import os
import shutil

import h5py
import numpy as np
import pytest
import yaml

from gimbal_reduction.reduction import models
from gimbal_reduction.results.bench.oracle import synthetic_body
from gimbal_reduction.solver.bodydata import BODIES
from gimbal_reduction.solver.dynamics import scenes
from tests.reduction.test_models import project_body_hash, write_body

D = 6            # modes per synthetic body


def write_reduction(path, body, config_hash):
    with h5py.File(path, "w") as f:
        f.attrs["body"] = body
        f["rank_frequency"] = np.arange(D)
        f["rank_xmx"] = np.array([3, 1, 0, 2, 5, 4])
        f["rank_xmgmx"] = np.array([3, 1, 0, 2, 4, 5])
        f.attrs["config_hash"] = config_hash


@pytest.fixture(scope="session")
def pristine(tmp_path_factory):
    """A folder of good inputs, never modified: modes/body{n}.h5, gimbal_reduction/reduction/body{n}.h5,
    scene.yaml (the thesis scene, 1 ms) and models/scene/xmx-2.h5 (made by gimbal_reduction.reduction.models)."""
    root = tmp_path_factory.mktemp("pristine")
    rng = np.random.default_rng(3)
    (root / "modes").mkdir()
    (root / "reduction").mkdir()
    for b in BODIES:
        d = synthetic_body(rng, b, n_nodes=8, rotations=(b % 2 == 0), n_modes=D, omega_max=3e3)
        write_body(root / "modes" / f"body{b}.h5", d, b)
        write_reduction(root / "reduction" / f"body{b}.h5", b, project_body_hash(b))
    write_scene(root / "scene.yaml")
    out = root / "models" / "scene" / "xmx-2.h5"
    rc = models.main(["--model", "xmx-2", "--scene", str(root / "scene.yaml"),
                      "--bodies", *[str(root / "modes" / f"body{b}.h5") for b in BODIES],
                      "--reductions", *[str(root / "reduction" / f"body{b}.h5") for b in BODIES],
                      "--out", str(out)])
    assert rc == 0
    return root


def write_scene(path, **changes):
    """The thesis scene of 1 ms, named by the file, with top-level ``changes``
    (key -> value: replaces the entry's value, or the whole entry if a dict / None deletes)."""
    raw = yaml.safe_load(open(os.path.join(scenes.SCENES_DIR, "thesis.yaml")))
    raw["name"] = os.path.splitext(os.path.basename(str(path)))[0]
    raw["duration"]["value"] = 1e-3
    for key, value in changes.items():
        if value is None:
            raw.pop(key, None)
        elif isinstance(value, dict) or key in ("name", "needs"):
            raw[key] = value
        else:
            raw[key]["value"] = value
    with open(path, "w") as f:
        yaml.safe_dump(raw, f)
    return path


@pytest.fixture
def work(tmp_path, pristine):
    """A private copy of the good inputs (cases corrupt their copy) and an empty output folder."""
    for sub in ("modes", "reduction", "models"):
        shutil.copytree(pristine / sub, tmp_path / sub)
    shutil.copy(pristine / "scene.yaml", tmp_path / "scene.yaml")
    (tmp_path / "out").mkdir()
    return tmp_path


def snapshot(*folders):
    """{path: (size, mtime_ns)} of every file (hidden ones too) under the folders."""
    out = {}
    for folder in folders:
        for dirpath, dirnames, filenames in os.walk(folder):
            out[dirpath] = None
            for name in filenames:
                p = os.path.join(dirpath, name)
                st = os.stat(p)
                out[p] = (st.st_size, st.st_mtime_ns)
    return out


@pytest.fixture
def refused(capsys):
    """refused(main, argv, culprit, *watched): run main(argv) in process; assert a non-zero
    status, one line on stderr containing every ``culprit`` string (str or tuple), nothing on
    stdout, and the watched folders unchanged.  Returns the message."""
    def check(main, argv, culprit, *watched):
        before = snapshot(*watched)
        rc = main([str(a) for a in argv])
        captured = capsys.readouterr()
        lines = captured.err.strip().splitlines()
        assert rc not in (0, None), f"accepted: {captured.out} {captured.err}"
        assert len(lines) == 1, f"not one line: {captured.err!r}"
        for text in (culprit if isinstance(culprit, tuple) else (culprit,)):
            assert text in lines[0], f"{text!r} not in {lines[0]!r}"
        assert snapshot(*watched) == before, "a watched folder changed"
        if os.environ.get("ROBUSTNESS_LOG"):            # the messages, for a review of their wording
            with open(os.environ["ROBUSTNESS_LOG"], "a") as log:
                log.write(f"{os.environ.get('PYTEST_CURRENT_TEST', '').split(' ')[0]}\t{lines[0]}\n")
        return lines[0]
    return check


def body_args(root):
    return ["--bodies", *[str(root / "modes" / f"body{b}.h5") for b in BODIES]]


def reduction_args(root):
    return ["--reductions", *[str(root / "reduction" / f"body{b}.h5") for b in BODIES]]

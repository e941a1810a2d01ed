"""Files of another configuration, refused by every stage that reads them when given --config (as the
workflow's rules give it, --config {CONFIG}): one line naming the file, the configuration and the
target to rerun with it, before any work, nothing written (gimbal_reduction/solver/bodyconfig.py).

The synthetic inputs carry the config hashes the project's configuration gives them; ``foreign``
relabels them as made from another one, ``current`` as the configuration's own again (the control).
Without --config a stage checks against the run's configuration (config/config.yaml)."""
import json

import h5py
import pytest

from gimbal_reduction.reduction import load_aware, models, stage
from gimbal_reduction.results.bench import truth_basis
from gimbal_reduction.results.study import run_scene
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.bodydata import BODIES
from gimbal_reduction.workflow import config as cfgmod

from .conftest import body_args, reduction_args

CONFIG = str(cfgmod.DEFAULT_CONFIG)


def current(work):
    """Relabel the copied body and reduction files as made from the project's configuration."""
    expected = bodyconfig.expected_hashes(CONFIG)
    for b in BODIES:
        for kind in ("modes", "reduction"):
            with h5py.File(work / kind / f"body{b}.h5", "r+") as f:
                f.attrs["config_hash"] = expected[b]
                f.attrs["body"] = b
    return expected


def foreign(work):
    """Relabel the copied body and reduction files as made from another configuration."""
    for b in BODIES:
        for kind in ("modes", "reduction"):
            with h5py.File(work / kind / f"body{b}.h5", "r+") as f:
                f.attrs["config_hash"] = "0123456789ab"


def culprit(path):
    return (str(path), "another configuration", f"--forcerun {path} --configfile {CONFIG}")


def test_reduction_stage(work, refused):
    foreign(work)
    body = work / "modes" / "body3.h5"
    refused(stage.main, ["--body-file", body, "--out", work / "out" / "r.h5", "--config", CONFIG, "--quiet"],
            culprit(body), work / "out")


def test_load_ranking_body_file(work, refused):
    foreign(work)
    refused(load_aware.main, ["--scene", work / "scene.yaml", *body_args(work), *reduction_args(work),
                              "--config", CONFIG, "--out", work / "out" / "l.h5"],
            culprit(work / "modes" / "body2.h5"), work / "out")


def test_load_ranking_reduction_file(work, refused):
    current(work)
    path = work / "reduction" / "body4.h5"
    with h5py.File(path, "r+") as f:
        f.attrs["config_hash"] = "0123456789ab"
    refused(load_aware.main, ["--scene", work / "scene.yaml", *body_args(work), *reduction_args(work),
                              "--config", CONFIG, "--out", work / "out" / "l.h5"], culprit(path), work / "out")


def test_reduced_model(work, refused):
    foreign(work)
    refused(models.main, ["--model", "freq-2", "--scene", work / "scene.yaml", *body_args(work),
                          "--config", CONFIG, "--out", work / "out" / "m.h5"],
            culprit(work / "modes" / "body2.h5"), work / "out")


def test_study_scene(work, refused):
    foreign(work)
    refused(run_scene.main, ["--scene", work / "scene.yaml", "--models", "freq-2", "xmx-2", *body_args(work),
                             *reduction_args(work), "--out-dir", work / "out", "--config", CONFIG],
            culprit(work / "modes" / "body2.h5"), work / "out")


def test_study_scene_ranking_of_other_body_files(work, refused):
    """A load-aware ranking records the four body hashes it was made from."""
    current(work)
    ranking = work / "load.h5"
    with h5py.File(ranking, "w") as f:
        f.attrs["body_config_hashes"] = json.dumps(["synthetic"] * 4)
    refused(run_scene.main, ["--scene", work / "scene.yaml", "--models", "load-2", *body_args(work),
                             *reduction_args(work), "--load-ranking", ranking, "--out-dir", work / "out",
                             "--config", CONFIG], (str(ranking), "body files of another configuration"),
            work / "out")


def test_truth_basis(work, refused):
    foreign(work)
    refused(truth_basis.main, [*body_args(work), "--scenes", work / "scene.yaml", "--config", CONFIG,
                               "--out", work / "out" / "t.json"],
            culprit(work / "modes" / "body2.h5"), work / "out")


@pytest.mark.parametrize("stage_main, argv", [
    (models.main, ["--model", "freq-2", "--scene", "{scene}", "--bodies", *["{modes}/body%d.h5" % b for b in BODIES],
                   "--out", "{out}/m.h5"]),
    (stage.main, ["--body-file", "{modes}/body3.h5", "--out", "{out}/r.h5", "--quiet"]),
], ids=["model", "reduce"])
def test_the_configuration_in_use_is_the_default(stage_main, argv, work, refused):
    """No --config: the stage checks against the run's configuration all the same."""
    foreign(work)
    argv = [a.format(scene=work / "scene.yaml", modes=work / "modes", out=work / "out") for a in argv]
    refused(stage_main, argv, ("modes/body", "another configuration"), work / "out")


def test_file_of_unknown_configuration(work, refused):
    current(work)
    path = work / "modes" / "body5.h5"
    with h5py.File(path, "r+") as f:
        del f.attrs["config_hash"]
    refused(stage.main, ["--body-file", path, "--out", work / "out" / "r.h5", "--config", CONFIG, "--quiet"],
            (str(path), "unknown"), work / "out")


def test_files_of_the_current_configuration_pass(work):
    """The control: relabelled, every kind of file passes (and a missing one is left to its reader)."""
    expected = current(work)
    ranking = work / "load.h5"
    with h5py.File(ranking, "w") as f:
        f.attrs["body_config_hashes"] = json.dumps([expected[b] for b in BODIES])
    files = [work / k / f"body{b}.h5" for k in ("modes", "reduction") for b in BODIES]
    bodyconfig.check_files([*files, ranking, work / "missing.h5"], CONFIG)
    bodyconfig.check_files(files, None)                      # no configuration: nothing checked
    other = cfgmod.load_config(CONFIG)
    other["material"]["density"]["value"] *= 1.01
    with pytest.raises(bodyconfig.BodyFileError, match="another configuration"):
        bodyconfig.check_files(files, other)

"""Bad model names given to reduction.models: refused in one line naming the model, before any
body file is reduced, nothing written."""
import pytest

from reduction import models

from .conftest import body_args, reduction_args

NAMES = {
    "fre-10": "unknown model",
    "freq-10": "only 6 computed",
    "freq-1,2,3": "counts must be",
    "static-2@6:output_motor_fz": "static spec",
    "static-2@2:output_motor_fq": "unknown load case",
    "static-2@5:output_motor_fz": "no output bearings",
    "static-2@2:output_motor_fz@2:output_motor_fx": "given twice",
    "truth@2:output_motor_fz": "takes no static modes",
    "freq--1": "unknown model",
}


@pytest.mark.parametrize("name", sorted(NAMES))
def test_bad_model_name(name, work, refused):
    argv = ["--model", name, "--scene", work / "scene.yaml", *body_args(work), *reduction_args(work),
            "--out", work / "out" / "m.h5"]
    refused(models.main, argv, (name, NAMES[name]), work / "out")

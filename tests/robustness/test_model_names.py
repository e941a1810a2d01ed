"""Bad model names given to gimbal_reduction.reduction.models: refused in one line naming the model, before any
body file is reduced, nothing written."""
import pytest

from gimbal_reduction.reduction import models

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


def test_every_model_the_workflow_names_passes_the_dag_check():
    """No false refusal when the DAG is built (gimbal_reduction.reduction.models.check_name, workflow/rules/common.smk):
    the study's models and every shipped scene's needs.models at the config's 100 modes per body, the
    .test scene's at its 12."""
    import glob
    import os

    from gimbal_reduction.results.study.cases import study_models
    from gimbal_reduction.solver.dynamics import scenes
    names = set(study_models()) | set(study_models(extended=False)) | {"truth"}
    for path in glob.glob(os.path.join(scenes.SCENES_DIR, "*.yaml")):
        names |= set(scenes.load_scene(path).models)
    for name in sorted(names):
        models.check_name(name, 100)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    for name in scenes.load_scene(os.path.join(root, ".test", "config", "scenes", "short.yaml")).models:
        models.check_name(name, 12)
    with pytest.raises(models.ModelError, match="only 12 computed"):
        models.check_name("truth", 12)

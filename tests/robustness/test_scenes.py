"""Bad scene files given to simulate: refused in one line naming the file and the key before
the model file is read, no simulation file written."""
import pytest

from gimbal_reduction.solver.dynamics import simulate

from .conftest import write_scene

MODEL = ("models", "scene", "xmx-2.h5")

CASES = {
    "interval longer than duration": (dict(output_interval=2e-3), ("output_interval", "longer")),
    "interval not dividing the duration": (dict(output_interval=3e-4), ("output_interval", "divide")),
    "negative duration": (dict(duration=-1e-3), ("duration",)),
    "nan duration": (dict(duration=float("nan")), ("duration",)),
    "zero interval": (dict(output_interval=0.0), ("output_interval",)),
    "negative damping": (dict(damping_ratio=-0.1), ("damping_ratio",)),
    "three angles": (dict(initial_angles=[0.0, 0.0, 0.0]), ("initial_angles",)),
    "unit furlong": (dict(duration={"value": 1e-3, "unit": "furlong"}), ("duration",)),
    "unit of another dimension": (dict(duration={"value": 1e-3, "unit": "in"}), ("duration",)),
    "missing duration": (dict(duration=None), ("duration",)),
    "unknown key": (dict(durration={"value": 1, "unit": "s"}), ("durration",)),
    "name of another scene": (dict(name="thesis"), ("name", "thesis")),
    "needs: bad body": (dict(needs={"bodies": {"value": [1, 2], "unit": "body number"}}), ("needs.bodies",)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_scene(case, work, refused):
    changes, words = CASES[case]
    scene = write_scene(work / "bad.yaml", **changes)
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"], ("bad.yaml", *words), work / "out")


def test_duplicate_key(work, refused):
    scene = write_scene(work / "dup.yaml")
    scene.write_text(scene.read_text() + "damping_ratio: {value: 0.5, unit: '1'}\n")
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"], ("damping_ratio", "duplicate"), work / "out")


def test_invalid_yaml(work, refused):
    scene = work / "broken.yaml"
    scene.write_text("duration: {value: 1e-3, unit: s\nname: broken\n")
    refused(simulate.main, ["--scene", scene, "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"], ("broken.yaml", "YAML"), work / "out")


def test_unknown_scene_name(work, refused):
    refused(simulate.main, ["--scene", "no_such_scene", "--model-file", work.joinpath(*MODEL),
                            "--out", work / "out" / "s.h5"], ("no_such_scene",), work / "out")

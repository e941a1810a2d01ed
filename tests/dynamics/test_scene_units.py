"""Scene units (issue 15): every number is converted into the unit its key is read in; a bad
unit or a duplicate key is refused in one line naming the key."""
import copy
import glob
import math
import os

import pytest
import yaml

from gimbal_reduction.solver.dynamics import scenes


def _thesis_raw():
    return copy.deepcopy(scenes.load_scene("thesis").raw)


@pytest.mark.parametrize("path", sorted(glob.glob(os.path.join(scenes.SCENES_DIR, "*.yaml"))))
def test_scene_files_give_their_numbers_unchanged(path):
    """The exact-unit spellings of the shipped scenes give the file's numbers, bit for bit."""
    raw = yaml.safe_load(open(path))
    scene = scenes.load_scene(path)
    floats = lambda v: repr(tuple(float(x) for x in v) if isinstance(v, list) else float(v))  # noqa: E731
    for key in ("duration", "output_interval", "initial_angles", "initial_rates", "motor_torques",
                "damping_ratio"):
        assert repr(getattr(scene, key)) == floats(raw[key]["value"]), key
    cm = raw["case_motion"]
    for field, key in (("amplitude", "angular_acceleration_amplitude"), ("frequency", "angular_acceleration_frequency"),
                       ("phase", "angular_acceleration_phase"), ("omega0", "initial_angular_velocity")):
        assert repr(tuple(getattr(scene.case, field))) == floats(cm[key]["value"]), key


def test_scene_in_other_units_is_the_same_scene():
    raw = _thesis_raw()
    base = scenes.parse_scene(copy.deepcopy(raw))
    raw["duration"] = {"value": 15.0, "unit": "ms"}
    raw["initial_angles"] = {"value": [0.0, -90.0, 0.0, 0.0], "unit": "deg"}
    raw["motor_torques"] = {"value": [1.0, 0.0, 0.0, 0.0], "unit": "N*m"}
    cm = raw["case_motion"]
    cm["angular_acceleration_frequency"] = {"value": [4 * math.pi, 0.0, 0.0], "unit": "rad/s"}
    cm["angular_acceleration_amplitude"] = {"value": [180 / math.pi, 0.0, 0.0], "unit": "deg/s^2"}
    cm["angular_acceleration_phase"] = {"value": [0.0, 0.0, 0.0], "unit": "deg"}
    scene = scenes.parse_scene(raw)
    assert scene.duration == pytest.approx(base.duration, rel=1e-12)
    assert scene.initial_angles == pytest.approx(base.initial_angles, rel=1e-12)
    assert scene.motor_torques[0] == pytest.approx(1 / (0.45359237 * 9.80665 * 0.0254), rel=1e-12)
    assert scene.case.frequency == pytest.approx(base.case.frequency, rel=1e-12)
    assert scene.case.amplitude == pytest.approx(base.case.amplitude, rel=1e-12)


@pytest.mark.parametrize("key, unit, message", [
    ("duration", "furlong", "thesis.yaml: duration: unknown unit 'furlong'"),
    ("duration", "in", "thesis.yaml: duration: unit 'in' is a length, expected a time (s)"),
    ("initial_angles", "1", "thesis.yaml: initial_angles: unit '1' is dimensionless, expected an angle (rad)"),
    ("motor_torques", "lbf", "thesis.yaml: motor_torques: unit 'lbf' is a force, expected a torque"),
    ("damping_ratio", "s", "thesis.yaml: damping_ratio: unit 's' is a time, expected dimensionless"),
    ("case_motion.angular_acceleration_frequency", "1/s",
     "thesis.yaml: case_motion.angular_acceleration_frequency: unit '1/s' is 1/time"),
    ("case_motion.initial_angular_velocity", "parsec",
     "thesis.yaml: case_motion.initial_angular_velocity: unknown unit 'parsec'"),
])
def test_bad_scene_unit_is_refused_naming_the_key(key, unit, message):
    raw = _thesis_raw()
    node = raw
    for part in key.split("."):
        node = node[part]
    node["unit"] = unit
    with pytest.raises(scenes.SceneError) as err:
        scenes.parse_scene(raw, origin="thesis.yaml")
    assert str(err.value).startswith(message) and "\n" not in str(err.value), str(err.value)


def test_duplicate_scene_key_is_refused(tmp_path):
    text = open(os.path.join(scenes.SCENES_DIR, "thesis.yaml")).read()
    line = next(l for l in text.splitlines(keepends=True) if l.startswith("duration:"))
    path = tmp_path / "thesis.yaml"
    path.write_text(text.replace(line, line + line.replace("0.015", "0.03")))
    with pytest.raises(scenes.SceneError) as err:
        scenes.load_scene(str(path))
    message = str(err.value)
    assert message.startswith("thesis.yaml: duration: duplicate key in ") and str(path) in message, message
    assert "\n" not in message
    nested = text.replace("  angular_acceleration_phase:", "  angular_acceleration_frequency: {value: [1, 0, 0], "
                          "unit: Hz}\n  angular_acceleration_phase:")
    path.write_text(nested)
    with pytest.raises(scenes.SceneError, match=r"^thesis.yaml: case_motion.angular_acceleration_frequency: "
                                                r"duplicate key"):
        scenes.load_scene(str(path))

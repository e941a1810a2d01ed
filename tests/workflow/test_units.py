"""Units (issue 15): every {value, unit} is converted into the unit its key is read in, a bad
unit or a duplicate YAML key is refused in one line naming the key."""
import copy
import json
import math

import pytest
import yaml

from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow import units, yamlfile
from gimbal_reduction.workflow.config import ROOT

# exact definitions, written out independently of the registry
LBF = 0.45359237 * 9.80665       # N
INCH = 0.0254                    # m


def q(value, unit):
    return {"value": value, "unit": unit, "source": "test"}


def one_line_error(config, fragment):
    with pytest.raises(cfgmod.ConfigError) as info:
        cfgmod.validate(config)
    message = str(info.value)
    assert "\n" not in message and fragment in message, message
    return message


@pytest.mark.parametrize("expected, entry, want", [
    ("lbf*s^2/in^4", q(2700, "kg/m^3"), 2700 * INCH ** 4 / LBF),
    ("lbf*s^2/in^4", q(2.7, "g/cm^3"), 2700 * INCH ** 4 / LBF),
    ("lbf*s^2/in^4", q(0.0026, "slug/in^3"), 0.0026 / 12),
    ("lbf/in^2", q(70.0, "GPa"), 70e9 * INCH ** 2 / LBF),
    ("lbf/in^2", q(1.0e7, "psi"), 1.0e7),
    ("lbf/in^2", q(1.0e4, "ksi"), 1.0e7),
    ("lbf/in^2", q(6.9e10, "N/m^2"), 6.9e10 * INCH ** 2 / LBF),
    ("in", q(6.35, "mm"), 0.25),
    ("in", q(0.5, "ft"), 6.0),
    ("deg", q(math.pi / 4, "rad"), 45.0),
    ("deg", q(0.125, "turn"), 45.0),
    ("rad", q([90.0, -180.0], "deg"), [math.pi / 2, -math.pi]),
    ("Hz", q([4 * math.pi, 0.0], "rad/s"), [2.0, 0.0]),
    ("Hz", q(120.0, "rpm"), 2.0),
    ("rad/s", q(1.0, "Hz"), 2 * math.pi),
    ("rad/s^2", q(180.0, "deg/s^2"), math.pi),
    ("s", q(15.0, "ms"), 0.015),
    ("in*lbf", q([1.0], "N*m"), [1.0 / (LBF * INCH)]),
    ("in*lbf", q(2.0, "lbf*in"), 2.0),
    ("in*lbf", q(2.0, "in lbf"), 2.0),
    ("(rad/s)^2", q(1.0, "rad^2/s^2"), 1.0),
    ("1", q(10.0, "%"), 0.1),
])
def test_conversion(expected, entry, want):
    got = units.convert(entry, expected, "key")
    assert got == pytest.approx(want, rel=1e-12, abs=1e-300)


@pytest.mark.parametrize("unit", ["lbf*s^2/in^4", "lbf * s ** 2 / in ** 4", "lbf*s^2/in^4 (of the thesis)"])
def test_the_keys_unit_keeps_the_value_object(unit):
    value = 2.1666666666666667e-4
    entry = q(value, unit)
    assert units.convert(entry, "lbf*s^2/in^4", "material.density") is entry["value"]
    count = q(100, "1 (SLEPc relative)")
    assert units.convert(count, "1", "modes.count") is count["value"]     # an int stays an int


@pytest.mark.parametrize("expected, unit, fragment", [
    ("lbf*s^2/in^4", "furlong", "unknown unit 'furlong'"),
    ("in", "", "no unit given"),
    ("in", "in*", "unknown unit 'in*'"),
    ("lbf*s^2/in^4", "kg", "unit 'kg' is a mass, expected a density"),
    ("lbf/in^2", "lbf/in", "expected a pressure"),
    ("1", "deg", "unit 'deg' is an angle, expected dimensionless"),
    ("rad", "1", "unit '1' is dimensionless, expected an angle"),
    ("Hz", "1/s", "unit '1/s' is 1/time, expected an angular velocity or frequency"),
    ("in*lbf", "N", "is a force, expected a torque"),
    (("sign of local x",), "in", "unit must be 'sign of local x'"),
])
def test_bad_unit_is_refused_naming_the_key(expected, unit, fragment):
    with pytest.raises(units.UnitError) as info:
        units.convert(q(1.0, unit), expected, "some.key")
    message = str(info.value)
    assert "\n" not in message and message.startswith("some.key: ") and fragment in message, message


def test_every_config_quantity_has_a_unit(config):
    """Each {value, unit} key of the shipped config is read through the table (none skipped)."""
    def walk(node, path):
        for key, entry in node.items():
            dotted = f"{path}.{key}" if path else key
            if isinstance(entry, dict) and "value" in entry:
                assert cfgmod.unit_of(dotted) is not None, dotted
            elif isinstance(entry, dict):
                walk(entry, dotted)
    walk(config, "")


def test_shipped_config_is_read_unchanged():
    """The exact-unit spellings of config.yaml give the very numbers (and types) of the file."""
    raw = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    loaded = cfgmod.load_config()
    assert json.dumps(loaded, sort_keys=True) == json.dumps(raw, sort_keys=True)
    assert loaded == raw


def _si_config(raw):
    si = copy.deepcopy(raw)
    m = si["material"]
    m["density"] = q(m["density"]["value"] * LBF / INCH ** 4, "kg/m^3")
    m["youngs_modulus"] = q(m["youngs_modulus"]["value"] * LBF / INCH ** 2 / 1e9, "GPa")
    si["bodies"]["inner_gimbal"]["thickness"] = q(si["bodies"]["inner_gimbal"]["thickness"]["value"] * 25.4, "mm")
    si["eccentric_mass"]["angle"] = q(math.radians(si["eccentric_mass"]["angle"]["value"]), "rad")
    return si


def test_si_config_gives_the_inch_values():
    raw = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    si = _si_config(raw)
    assert si["material"]["density"]["value"] == pytest.approx(2315.494, rel=1e-6)
    loaded, reference = cfgmod.validate(si), cfgmod.validate(raw)
    for key in ("material.density", "material.youngs_modulus", "bodies.inner_gimbal.thickness",
                "eccentric_mass.angle"):
        assert cfgmod.value(loaded, key) == pytest.approx(cfgmod.value(reference, key), rel=1e-9), key
    assert loaded["material"]["density"]["unit"] == "lbf*s^2/in^4"      # the unit it now holds


def test_issue_density_in_si_is_converted(config_copy):
    """The issue's case: 2700 kg/m^3 is no longer read as 2700 lbf*s^2/in^4."""
    config_copy["material"]["density"] = q(2700, "kg/m^3")
    density = cfgmod.value(cfgmod.validate(config_copy), "material.density")
    assert density == pytest.approx(2.5264587655986e-4, rel=1e-12)


def test_bounds_apply_to_the_converted_value(config_copy):
    config_copy["eccentric_mass"]["angle"] = q(1.7, "rad")            # 97 deg > 90 deg
    one_line_error(config_copy, "eccentric_mass.angle.value")
    config_copy["eccentric_mass"]["angle"] = q(1.5, "rad")
    cfgmod.validate(config_copy)


@pytest.mark.parametrize("key, unit, fragment", [
    ("material.density", "furlong", "config error at 'material.density': unknown unit 'furlong'"),
    ("material.density", "kg", "config error at 'material.density': unit 'kg' is a mass"),
    ("material.youngs_modulus", "in", "config error at 'material.youngs_modulus': unit 'in' is a length"),
    ("material.poissons_ratio", "deg", "config error at 'material.poissons_ratio': unit 'deg' is an angle"),
    ("bodies.middle_gimbal.width", "s", "config error at 'bodies.middle_gimbal.width': unit 's' is a time"),
    ("eccentric_mass.angle", "1", "config error at 'eccentric_mass.angle': unit '1' is dimensionless"),
    ("bodies.inner_gimbal.motor_side", "1", "config error at 'bodies.inner_gimbal.motor_side': unit must be"),
    ("simulation.integrator", "s", "config error at 'simulation.integrator': unit must be '-'"),
])
def test_bad_config_unit(config_copy, key, unit, fragment):
    node = config_copy
    for part in key.split("."):
        node = node[part]
    node["unit"] = unit
    one_line_error(config_copy, fragment)


def test_duplicate_config_key_is_refused(tmp_path):
    text = (ROOT / "config" / "config.yaml").read_text()
    line = "  poissons_ratio: {value: 0.3, unit: \"1\", source: \"thesis Table 2.3\"}\n"
    assert line in text
    bad = tmp_path / "dup.yaml"
    bad.write_text(text.replace(line, line + line.replace("0.3", "0.33")))
    with pytest.raises(cfgmod.ConfigError) as info:
        cfgmod.load_config(bad)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith("config error at 'material.poissons_ratio': duplicate key in "), message
    assert str(bad) in message and "line 8" in message


def test_duplicate_keys_at_any_depth():
    with pytest.raises(yamlfile.DuplicateKeyError) as info:
        yamlfile.load_text("a:\n  b: [{c: 1, c: 2}]\n", "f.yaml")
    assert info.value.key == "a.b.[0].c" and info.value.path == "f.yaml" and info.value.line == 2
    assert yamlfile.load_text("a: {b: 1}\nc: {b: 2}\n") == {"a": {"b": 1}, "c": {"b": 2}}


def test_the_memo_gives_pints_answers_and_never_keeps_a_refusal(tmp_path, monkeypatch):
    """In a Snakemake project (.snakemake/ exists) a fresh process answers a known pair from the
    memo file, without pint (the registry is made to fail), with pint's factor; a refused unit
    is refused again, naming the key; another salt (an edited units module) starts afresh."""
    from gimbal_reduction.workflow import memo
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".snakemake").mkdir()
    monkeypatch.setattr(units, "_MEMO", memo.DiskMemo("units", lambda: "salt-1"))
    expected = units.convert({"value": 2.0, "unit": "m"}, "in", "length")
    assert expected == pytest.approx(2.0 / 0.0254, rel=1e-15)
    with pytest.raises(units.UnitError, match="^mass: unit 'm' is a length"):
        units.convert({"value": 2.0, "unit": "m"}, "lb", "mass")
    assert (tmp_path / memo.FOLDER / "gimbal_reduction-memo-units.json").is_file()

    def no_pint():
        raise AssertionError("pint was asked")
    monkeypatch.setattr(units, "_MEMO", memo.DiskMemo("units", lambda: "salt-1"))
    monkeypatch.setattr(units, "quantity", lambda unit: no_pint())
    assert units.convert({"value": 2.0, "unit": "m"}, "in", "length") == expected
    assert units.convert({"value": [1, 2.0], "unit": "m"}, "in", "length") == [expected / 2, expected]
    with pytest.raises(AssertionError, match="pint was asked"):   # never kept: computed again
        units.convert({"value": 2.0, "unit": "m"}, "lb", "mass")
    monkeypatch.setattr(units, "_MEMO", memo.DiskMemo("units", lambda: "salt-2"))
    with pytest.raises(AssertionError, match="pint was asked"):   # another salt: nothing known
        units.convert({"value": 2.0, "unit": "m"}, "in", "length")


def test_outside_a_snakemake_project_the_memo_writes_nothing(tmp_path, monkeypatch):
    from gimbal_reduction.workflow import memo
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(units, "_MEMO", memo.DiskMemo("units", lambda: "salt-1"))
    assert units.convert({"value": 1.0, "unit": "ft"}, "in", "length") == pytest.approx(12.0, rel=1e-15)
    assert list(tmp_path.iterdir()) == []

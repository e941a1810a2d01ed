"""Config validation: every bad value stops with a one-line error naming the key."""
import copy

import pytest

from gimbal_reduction.workflow import config as cfgmod


def expect_error(config, fragment):
    with pytest.raises(cfgmod.ConfigError) as info:
        cfgmod.validate(config)
    message = str(info.value)
    assert "\n" not in message
    assert fragment in message, message


def test_shipped_config_is_valid(config):
    assert cfgmod.value(config, "material.youngs_modulus") == 3.0e8
    assert cfgmod.value(config, "modes.count") == 100


def test_every_number_has_unit_and_source(config):
    def walk(node, path):
        if isinstance(node, dict) and "value" in node:
            assert node["unit"] and node["source"], path
        elif isinstance(node, dict):
            for k, v in node.items():
                walk(v, f"{path}.{k}")
        else:
            assert not isinstance(node, float), f"bare number at {path}"
    walk(config, "")


def test_negative_thickness(config_copy):
    config_copy["bodies"]["middle_gimbal"]["thickness"]["value"] = -0.25
    expect_error(config_copy, "bodies.middle_gimbal.thickness.value")


def test_typo_key(config_copy):
    config_copy["material"]["youngs_modulu"] = config_copy["material"].pop("youngs_modulus")
    expect_error(config_copy, "material")


def test_string_instead_of_number(config_copy):
    config_copy["material"]["density"]["value"] = "2.2e-4"
    expect_error(config_copy, "material.density.value")


def test_zero_mode_count(config_copy):
    config_copy["modes"]["count"]["value"] = 0
    expect_error(config_copy, "modes.count.value")


@pytest.mark.parametrize("count", [1, 9])
def test_fewer_modes_than_the_static_modes_keep(config_copy, count):
    """modes.count 1 would plan the study and stop in the reduction (its static modes keep the 10
    lowest), naming --static-kept: refused at validation, naming modes.count; 10 passes."""
    config_copy["modes"]["count"]["value"] = count
    expect_error(config_copy, "modes.count")
    config_copy["modes"]["count"]["value"] = cfgmod.MIN_MODES
    cfgmod.validate(config_copy)


def test_platform_bearings_inside_the_hole(config_copy):
    config_copy["bodies"]["stable_platform"]["outer_bearing_distance"]["value"] = 1.0
    config_copy["bodies"]["inner_gimbal"]["inner_bearing_distance"]["value"] = 1.0
    expect_error(config_copy, "bodies.stable_platform.outer_bearing_distance")


def test_ring_outer_bearing_inside_the_wall(config_copy):
    config_copy["bodies"]["outer_gimbal"]["outer_bearing_distance"]["value"] = 6.8
    expect_error(config_copy, "bodies.outer_gimbal.outer_bearing_distance")


def test_nested_joint_mismatch(config_copy):
    config_copy["bodies"]["middle_gimbal"]["outer_bearing_distance"]["value"] = 6.3
    expect_error(config_copy, "bodies.middle_gimbal.outer_bearing_distance")


def test_missing_file_and_bad_yaml(tmp_path):
    with pytest.raises(cfgmod.ConfigError, match="not found"):
        cfgmod.load_config(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("material: [unclosed\n")
    with pytest.raises(cfgmod.ConfigError, match="not valid YAML"):
        cfgmod.load_config(bad)


def test_body_parameters_and_output_motor_side(config):
    assert cfgmod.body_parameters(config, 2)["output_motor_side"] == 1   # body 3's motor at +x3 = +z2
    assert cfgmod.body_parameters(config, 3)["output_motor_side"] == -1  # body 4's motor at -x4 = -z3
    assert cfgmod.body_parameters(config, "stable_platform")["model"] == "solid"
    with pytest.raises(cfgmod.ConfigError, match="unknown body"):
        cfgmod.body_parameters(config, 7)


def test_body_inputs_track_only_what_the_body_reads(config_copy, config):
    before = cfgmod.inputs_hash(cfgmod.body_inputs(config, 2))
    config_copy["bodies"]["middle_gimbal"]["width"]["value"] = 0.6
    assert cfgmod.inputs_hash(cfgmod.body_inputs(config_copy, 2)) == before
    config_copy["bodies"]["outer_gimbal"]["width"]["value"] = 0.6
    assert cfgmod.inputs_hash(cfgmod.body_inputs(config_copy, 2)) != before


def test_body_inputs_hold_the_next_bodys_motor_side(config_copy, config):
    """Body 3's motor side places body 2's output bearings (its mesh regions and bearing points)."""
    mesh = cfgmod.body_inputs(config, 2)["mesh"]
    config_copy["bodies"]["middle_gimbal"]["motor_side"]["value"] = -1
    changed = cfgmod.body_inputs(config_copy, 2)["mesh"]
    assert (mesh["body"]["output_motor_side"], changed["body"]["output_motor_side"]) == (1, -1)
    assert cfgmod.inputs_hash(changed) != cfgmod.inputs_hash(mesh)


def test_body_inputs_mesh_size_override(config):
    assert cfgmod.body_inputs(config, 4)["mesh"]["size"] == cfgmod.value(config, "mesh.ring_size")
    assert cfgmod.body_inputs(config, 4, 0.5)["mesh"]["size"] == 0.5
    assert cfgmod.body_inputs(config, 5)["mesh"]["size"] == cfgmod.value(config, "mesh.platform_size")
    # only the platform's mesh reads the rim-patch half-angles; only a shell the shell settings
    assert "bearing_half_angle" in cfgmod.body_inputs(config, 5)["mesh"]
    assert "bearing_half_angle" not in cfgmod.body_inputs(config, 2)["mesh"]
    assert "shell" in cfgmod.body_inputs(config, 2) and "solid_degree" in cfgmod.body_inputs(config, 5)
    with pytest.raises(cfgmod.ConfigError, match="unknown check"):
        cfgmod.check_inputs(config, "nope")


def test_loaded_config_is_kept_per_file_state_and_handed_out_as_copies(tmp_path):
    """load_config keeps a validated file in process (the study loads it ~150 times): a
    caller's change to the dict it got must not reach the next caller, and a rewritten file
    (new size or modification time) is read and validated again, errors included."""
    import os
    import shutil
    path = tmp_path / "config.yaml"
    shutil.copy(cfgmod.DEFAULT_CONFIG, path)
    first = cfgmod.load_config(path)
    first["modes"]["count"]["value"] = -1
    assert cfgmod.load_config(path)["modes"]["count"]["value"] > 0
    text = path.read_text()
    key = "poissons_ratio"
    assert key in text
    bad = text.replace(key, "poissons_ration", 1)
    path.write_text(bad)
    st = os.stat(path)
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    with pytest.raises(cfgmod.ConfigError, match="poissons_ration"):
        cfgmod.load_config(path)


def test_a_config_with_aliases_or_deep_nesting_is_refused_in_one_line(tmp_path):
    """The billion laughs (nine nested aliases of nine) and a 100,000-deep document: refused by
    the limits before libyaml builds anything, naming the file and the limit."""
    from gimbal_reduction.workflow import config as cfgmod
    laughs = tmp_path / "laughs.yaml"
    laughs.write_text("a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{b}: &{b} [{', '.join(['*' + a] * 9)}]\n" for a, b in zip("abcdefgh", "bcdefghi")))
    deep = tmp_path / "deep.yaml"
    deep.write_text("x: " + "{a: " * 100_000 + "1" + "}" * 100_000 + "\n")
    for path, words in ((laughs, ("laughs.yaml line 2", "alias")), (deep, ("deep.yaml line 1", "32 deep"))):
        with pytest.raises(cfgmod.ConfigError) as info:
            cfgmod.read_config_file(path)
        message = str(info.value)
        assert "\n" not in message and all(w in message for w in words), message


def test_a_config_that_passed_is_known_and_a_refused_one_is_checked_again(tmp_path, monkeypatch):
    """In a Snakemake project the resolved form of a config that passed is kept (memo.DiskMemo):
    a fresh process gets the same resolved config without the schema check; one edited value is
    checked again, and a refused config is refused every time."""
    from gimbal_reduction.workflow import memo
    shipped = cfgmod.read_config_file(cfgmod.DEFAULT_CONFIG)
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".snakemake").mkdir()
    monkeypatch.setattr(cfgmod, "_MEMO", memo.DiskMemo("config", lambda: "salt-1"))
    resolved = cfgmod.validate(shipped)
    checks = []
    real = cfgmod._validate
    monkeypatch.setattr(cfgmod, "_validate", lambda c: checks.append(1) or real(c))
    monkeypatch.setattr(cfgmod, "_MEMO", memo.DiskMemo("config", lambda: "salt-1"))
    assert cfgmod.validate(shipped) == resolved and checks == []
    bad = copy.deepcopy(shipped)
    bad["modes"]["count"]["value"] = 3
    for _ in range(2):
        with pytest.raises(cfgmod.ConfigError, match="modes.count"):
            cfgmod.validate(bad)
    assert len(checks) == 2

"""Scenes state what they need (issue 6): elastic bodies and the models their results use."""
import copy
import glob
import os

import numpy as np
import pytest

from gimbal_reduction.reduction import models
from gimbal_reduction.reduction import names
from gimbal_reduction.solver.dynamics import scenes


def _thesis_raw():
    return copy.deepcopy(scenes.load_scene("thesis").raw)


def test_every_scene_file_parses_and_declares_valid_needs():
    rankings = {b: {k: np.arange(100) for k in models.RANKING_KEYS.values()} for b in models.BODIES}
    for path in sorted(glob.glob(os.path.join(scenes.SCENES_DIR, "*.yaml"))):
        scene = scenes.load_scene(path)
        assert set(scene.elastic_bodies) <= set(scenes.ALL_BODIES)
        for name in scene.models:
            if name.split("-")[0] not in ("load", "global"):     # need a scene ranking file
                models.model_spec(name, rankings)


def test_needs_default_to_all_bodies_and_no_models():
    raw = _thesis_raw()
    raw.pop("needs")
    scene = scenes.parse_scene(raw)
    assert scene.elastic_bodies == (2, 3, 4, 5) and scene.models == ()


@pytest.mark.parametrize("needs, message", [
    ({"bodies": {"value": [2, 6], "unit": "body number"}}, "needs.bodies must be distinct body numbers"),
    ({"bodies": {"value": [2, 2], "unit": "body number"}}, "needs.bodies must be distinct body numbers"),
    ({"bodies": {"value": [2], "unit": "rad"}}, "needs.bodies: unit must be 'body number'"),
    ({"models": {"value": "truth", "unit": "model name"}}, "needs.models must be a list"),
    ({"models": {"value": ["truth", ""], "unit": "model name"}}, "needs.models must be model names"),
    ({"bodys": {"value": [2], "unit": "body number"}}, "unknown needs key(s) bodys"),
    ([2, 3], "needs must be a mapping"),
])
def test_bad_needs_give_one_line_errors(needs, message):
    _assert_refused("needs", needs, message)


def _assert_refused(key, entry, message):
    """The thesis scene with raw[key] = entry is refused in one line holding message."""
    raw = _thesis_raw()
    raw[key] = entry
    with pytest.raises(scenes.SceneError) as err:
        scenes.parse_scene(raw, origin="thesis.yaml")
    assert message in str(err.value) and "\n" not in str(err.value)


def test_what_a_scene_needs_does_not_change_its_physics_hash():
    raw = _thesis_raw()
    base = scenes.parse_scene(raw).config_hash()
    raw["needs"]["models"]["value"].append("freq-3")
    raw["description"] = "edited"
    assert scenes.parse_scene(raw).config_hash() == base
    raw["duration"]["value"] = 0.02
    assert scenes.parse_scene(raw).config_hash() != base


def test_model_selection_sources_and_body_restriction():
    assert not any(names.needs_reduction_rankings(m) for m in
                   ("truth", "rigid", "freq-10", "static-8", "static-freq-8@2:output_motor_fz"))
    assert all(names.needs_reduction_rankings(m) for m in
               ("xmx-10", "xmgmx-5,5,5,5", "static-xmx-8", "load-10", "global-40"))
    eig = {b: np.array([9.0, 1.0, 4.0]) for b in models.BODIES}
    ranks = models.frequency_rankings({b: {"eigenvalues": e} for b, e in eig.items()})
    assert ranks[2]["rank_frequency"].tolist() == [1, 2, 0]
    spec = models.model_spec("static-2", ranks)
    rigid_outer = models.restrict_to_bodies(spec, (3, 4, 5))
    assert rigid_outer.n_modes(2) == 0 and rigid_outer.n_modes(3) == 3
    assert rigid_outer.kept[3].tolist() == [1, 2] and rigid_outer.name == spec.name


def test_a_scene_may_state_its_exponential_tolerance():
    """The optional exponential_tolerance (unit 1): long states 5e-7 (its attitude integrates the
    rates' errors over 1 s); a scene without it leaves the integrator's default."""
    assert scenes.load_scene("long").exponential_tolerance == 5e-7
    assert scenes.load_scene("thesis").exponential_tolerance is None
    raw = _thesis_raw()
    raw["exponential_tolerance"] = {"value": 2e-6, "unit": "1", "source": "test"}
    assert scenes.parse_scene(raw).exponential_tolerance == 2e-6
    base = scenes.parse_scene(_thesis_raw()).config_hash()
    assert scenes.parse_scene(raw).config_hash() != base          # it changes the simulations


@pytest.mark.parametrize("entry, message", [
    ({"value": 0.0, "unit": "1"}, "exponential_tolerance must be > 0"),
    ({"value": -1e-6, "unit": "1"}, "exponential_tolerance must be > 0"),
    ({"value": float("nan"), "unit": "1"}, "exponential_tolerance: non-finite value"),
    ({"value": 1e-6, "unit": "rad"}, "exponential_tolerance"),
    (1e-6, "exponential_tolerance: expected {value, unit, source}"),
])
def test_bad_exponential_tolerance_gives_one_line_errors(entry, message):
    _assert_refused("exponential_tolerance", entry, message)

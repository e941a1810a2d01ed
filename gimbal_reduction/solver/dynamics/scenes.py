"""Scenes: initial state, case motion, motor torques, duration (config/scenes/*.yaml).

A scene file holds, for every number, ``{value, unit, source}`` (see
config/scenes/thesis.yaml).  ``load_scene`` validates it completely before any
integration: unknown or missing keys, wrong lengths, non-finite values, a
negative duration or a non-positive output interval raise SceneError with a
one-line message.  Every number is read through :func:`gimbal_reduction.workflow.units.convert`
into the unit its key is read in (``_TOP``, ``_CASE``): another consistent unit
(``deg`` for ``rad``, ``rad/s`` for ``Hz``, ``ms`` for ``s``) is converted, an
unknown unit or one of another dimension is refused naming the key, and a
duplicate key in the file is refused (:mod:`gimbal_reduction.workflow.yamlfile`).

A scene also states what it needs (optional ``needs`` block, so that the
workflow computes nothing else):

* ``needs.bodies``: the elastic bodies (default all of 2..5); the others are
  rigid in every model simulated on this scene, so neither their reduction nor
  their modal integrals are computed (their mass properties still come from
  their body file);
* ``needs.models``: the reduced models whose simulations make up the scene's
  results (``snakemake results/sim/{scene}/needs.done`` builds exactly those).
A scene may also state the accuracy it needs (optional ``exponential_tolerance``,
unit ``1``): the exponential integrator's tolerance for every simulation of the
scene (``simulate.run_scene``) unless one is given (``--tol``, a fixed ``--step``).
A long scene needs it: the platform attitude integrates the rates' errors over the
whole run (``long``: docs/exponential.md Section 5).

A scene is named by its file, and the name names its outputs and Snakemake targets
(results/sim/{scene}/...): ``NAME_RULE``, checked by ``check_scene_name`` for the command lines
and the workflow alike.  Its duration is positive, and its rates (``initial_rates``,
``case_motion.initial_angular_velocity``) at most ``MAX_RATE``.
"""

import hashlib
import json
import math
import os
import re
from dataclasses import dataclass

import numpy as np
import yaml

from gimbal_reduction.solver.dynamics.multibody import CaseMotion
from gimbal_reduction.workflow import units, yamlfile
from gimbal_reduction.workflow import config as cfgmod

SCENES_DIR = str(cfgmod.ROOT / "config" / "scenes")   # the project's (workflow.config.project_dir)

# key -> (length or None for a scalar, the unit it is read in: gimbal_reduction.workflow.units.convert)
_TOP = {
    "duration": (None, "s"), "output_interval": (None, "s"),
    "initial_angles": (4, "rad"), "initial_rates": (4, "rad/s"),
    "motor_torques": (4, "in*lbf"), "damping_ratio": (None, "1"),
}
_CASE = {
    "angular_acceleration_amplitude": (3, "rad/s^2"), "angular_acceleration_frequency": (3, "Hz"),
    "angular_acceleration_phase": (3, "rad"), "initial_angular_velocity": (3, "rad/s"),
}


# The rule for scene names: ASCII letters, digits, '_' and '-' (a name is a folder of results/sim/
# and a Snakemake wildcard: no space, no '/', nothing a shell or a file system reads otherwise).
NAME_PATTERN = re.compile(r"[A-Za-z0-9_-]+")
NAME_RULE = "a scene name is ASCII letters, digits, '_' and '-' (it names the scene's outputs)"

# [rad/s] The largest rate a scene may give the gimbals or the case: 1e4 rad/s (95,000 rpm) is
# near the chain's lowest elastic mode, ~1.1e4 rad/s (config/scenes/spin.yaml: 62.8 rad/s is
# 5.6e-3 of it), where a rigid gimbal motion with small elastic deformations, the model of this
# project, no longer holds; at 1e5 rad/s the default integrator's step fell to 6e-13 s.
MAX_RATE = 1e4

ALL_BODIES = (2, 3, 4, 5)
_NEEDS = {"bodies": ("body number",), "models": ("model name",)}   # labels, given exactly


class SceneError(ValueError):
    """A scene file that cannot be used."""


@dataclass(frozen=True)
class Scene:
    name: str
    description: str
    duration: float
    output_interval: float
    initial_angles: tuple
    initial_rates: tuple
    motor_torques: tuple
    case: CaseMotion
    damping_ratio: float
    raw: dict
    elastic_bodies: tuple = ALL_BODIES
    models: tuple = ()
    exponential_tolerance: float = None     # [1] the scene's exponential tolerance (None: the default)

    @property
    def physics(self):
        """The raw scene without ``needs`` and ``description``: what a simulation depends on."""
        return {k: v for k, v in self.raw.items() if k not in ("needs", "description")}

    def tighter_tolerance(self, tol):
        """The tighter of an exponential tolerance tol and the scene's own exponential_tolerance
        (tol when the scene states none): the tolerance the workflow simulates the scene at
        (workflow/rules/common.smk) and ``gimbal_reduction.results.bench.exponential_accuracy`` checks it at."""
        return tol if self.exponential_tolerance is None else min(tol, self.exponential_tolerance)

    def config_hash(self):
        """Hash of ``physics``: editing what the scene needs does not invalidate its simulations."""
        return hashlib.sha256(json.dumps(self.physics, sort_keys=True, default=str).encode()).hexdigest()[:16]

    def loads_hash(self):
        """Hash of what the scene does to the chain (``physics`` without its name): a load-aware
        ranking made for one scene holds for every scene of the same loads."""
        loads = {k: v for k, v in self.physics.items() if k != "name"}
        return hashlib.sha256(json.dumps(loads, sort_keys=True, default=str).encode()).hexdigest()[:16]


def _converted(origin, key, entry, unit):
    """``entry``'s value in ``unit`` (gimbal_reduction.workflow.units.convert); SceneError naming the key."""
    try:
        return units.convert(entry, unit, key)
    except units.UnitError as exc:
        raise SceneError(f"{origin}: {exc}") from None


def _number(origin, key, entry, length, unit):
    where = f"{origin}: {key}"
    if not isinstance(entry, dict) or "value" not in entry:
        raise SceneError(f"{where}: expected {{value, unit, source}}, got {entry!r}")
    extra = set(entry) - {"value", "unit", "source"}
    if extra:
        raise SceneError(f"{where}: unknown field(s) {', '.join(sorted(extra))}")
    value = _converted(origin, key, entry, unit)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SceneError(f"{where}: not a number: {value!r}") from None
    if length is None:
        if arr.shape != ():
            raise SceneError(f"{where}: expected a scalar, got {value!r}")
    elif arr.shape != (length,):
        raise SceneError(f"{where}: expected {length} values, got {value!r}")
    if not np.all(np.isfinite(arr)):
        raise SceneError(f"{where}: non-finite value {value!r}")
    return float(arr) if length is None else tuple(float(v) for v in arr)


def _needs(where, block):
    """(elastic bodies, model names) of a scene's optional ``needs`` block."""
    if block is None:
        return ALL_BODIES, ()
    if not isinstance(block, dict):
        raise SceneError(f"{where}: needs must be a mapping with keys {', '.join(_NEEDS)}")
    unknown = set(block) - set(_NEEDS)
    if unknown:
        raise SceneError(f"{where}: unknown needs key(s) {', '.join(sorted(unknown))} "
                         f"(known: {', '.join(_NEEDS)})")
    out = {}
    for key, unit in _NEEDS.items():
        entry = block.get(key)
        if entry is None:
            continue
        if not isinstance(entry, dict) or "value" not in entry or set(entry) - {"value", "unit", "source"}:
            raise SceneError(f"{where}: needs.{key} must be {{value, unit, source}}, got {entry!r}")
        value = _converted(where, f"needs.{key}", entry, unit)
        if not isinstance(value, list):
            raise SceneError(f"{where}: needs.{key} must be a list, got {value!r}")
        out[key] = value
    bodies = out.get("bodies", list(ALL_BODIES))
    if any(isinstance(b, bool) or b not in ALL_BODIES for b in bodies) or len(set(bodies)) != len(bodies):
        raise SceneError(f"{where}: needs.bodies must be distinct body numbers out of 2, 3, 4, 5, "
                         f"got {bodies!r}")
    models = out.get("models", [])
    if any(not isinstance(m, str) or not m or "/" in m for m in models):
        raise SceneError(f"{where}: needs.models must be model names, got {models!r}")
    return tuple(sorted(bodies)), tuple(models)


def parse_scene(raw, origin="scene"):
    """Scene from a parsed YAML mapping; SceneError on anything invalid."""
    if not isinstance(raw, dict):
        raise SceneError(f"{origin}: a scene is a mapping, got {type(raw).__name__}")
    allowed = set(_TOP) | {"name", "description", "case_motion", "needs", "exponential_tolerance"}
    unknown = set(raw) - allowed
    if unknown:
        raise SceneError(f"{origin}: unknown key(s) {', '.join(sorted(unknown))} "
                         f"(known: {', '.join(sorted(allowed))})")
    missing = (set(_TOP) | {"name", "case_motion"}) - set(raw)
    if missing:
        raise SceneError(f"{origin}: missing key(s) {', '.join(sorted(missing))}")
    vals = {k: _number(origin, k, raw[k], *spec) for k, spec in _TOP.items()}
    cm = raw["case_motion"]
    if not isinstance(cm, dict):
        raise SceneError(f"{origin}: case_motion must be a mapping")
    unknown = set(cm) - set(_CASE)
    if unknown:
        raise SceneError(f"{origin}: unknown case_motion key(s) {', '.join(sorted(unknown))}")
    missing = set(_CASE) - set(cm)
    if missing:
        raise SceneError(f"{origin}: missing case_motion key(s) {', '.join(sorted(missing))}")
    case = {k: _number(origin, f"case_motion.{k}", cm[k], *spec) for k, spec in _CASE.items()}
    if vals["duration"] <= 0:
        raise SceneError(f"{origin}: duration must be > 0 s, got {vals['duration']:g} s")
    if vals["output_interval"] <= 0:
        raise SceneError(f"{origin}: output_interval must be > 0 s, got {vals['output_interval']}")
    duration, interval = vals["duration"], vals["output_interval"]
    if duration > 0 and interval > duration * (1 + 1e-12):
        raise SceneError(f"{origin}: output_interval {interval:g} s is longer than the duration "
                         f"{duration:g} s (only the two end samples would be kept): shorten it")
    if duration > 0:
        samples = duration / interval
        if abs(samples - round(samples)) > 1e-9 * max(samples, 1.0):
            raise SceneError(f"{origin}: output_interval {interval:g} s does not divide the duration "
                             f"{duration:g} s ({samples:.6g} intervals): choose one that does "
                             f"(e.g. {duration / max(round(samples), 1):.6g} s)")
    for key, rates in (("initial_rates", vals["initial_rates"]),
                       ("case_motion.initial_angular_velocity", case["initial_angular_velocity"])):
        if max(abs(r) for r in rates) > MAX_RATE:
            raise SceneError(f"{origin}: {key}: {max(abs(r) for r in rates):g} rad/s is above the "
                             f"{MAX_RATE:g} rad/s a scene may hold (near the chain's lowest elastic "
                             f"mode, where the model of small elastic motions stops holding)")
    if vals["damping_ratio"] < 0:
        raise SceneError(f"{origin}: damping_ratio must be >= 0, got {vals['damping_ratio']}")
    if any(f < 0 for f in case["angular_acceleration_frequency"]):
        raise SceneError(f"{origin}: case frequencies must be >= 0 Hz")
    elastic_bodies, models = _needs(origin, raw.get("needs"))
    tolerance = None
    if "exponential_tolerance" in raw:
        tolerance = _number(origin, "exponential_tolerance", raw["exponential_tolerance"], None, "1")
        if not tolerance > 0:
            raise SceneError(f"{origin}: exponential_tolerance must be > 0, got {tolerance:g}")
    return Scene(
        elastic_bodies=elastic_bodies, models=models, exponential_tolerance=tolerance,
        name=str(raw["name"]), description=str(raw.get("description", "")),
        duration=vals["duration"], output_interval=vals["output_interval"],
        initial_angles=vals["initial_angles"], initial_rates=vals["initial_rates"],
        motor_torques=vals["motor_torques"],
        case=CaseMotion(amplitude=case["angular_acceleration_amplitude"],
                        frequency=case["angular_acceleration_frequency"],
                        phase=case["angular_acceleration_phase"],
                        omega0=case["initial_angular_velocity"]),
        damping_ratio=vals["damping_ratio"], raw=raw)


def check_scene_name(name):
    """SceneError (one line) unless ``name`` follows ``NAME_RULE``."""
    if not NAME_PATTERN.fullmatch(str(name)):
        raise SceneError(f"scene name {str(name)!r} refused: {NAME_RULE}; rename the scene file")


def load_scene(name_or_path, scenes_dir=SCENES_DIR):
    """Scene by name (config/scenes/{name}.yaml) or path."""
    path = name_or_path if os.path.sep in str(name_or_path) or str(name_or_path).endswith(".yaml") \
        else os.path.join(scenes_dir, f"{name_or_path}.yaml")
    check_scene_name(os.path.splitext(os.path.basename(str(path)))[0])
    if not os.path.exists(path):
        known = sorted(f[:-5] for f in os.listdir(scenes_dir) if f.endswith(".yaml")) \
            if os.path.isdir(scenes_dir) else []
        raise SceneError(f"unknown scene {name_or_path!r} (known: {', '.join(known)})")
    try:
        raw = yamlfile.load_file(path)
    except yamlfile.DuplicateKeyError as exc:
        raise SceneError(f"{os.path.basename(path)}: {exc.key}: duplicate key in '{path}' line {exc.line} "
                         "(the last value would silently win)") from None
    except yamlfile.YAMLInputError as exc:
        raise SceneError(str(exc)) from None
    except yaml.YAMLError as exc:
        raise SceneError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    scene = parse_scene(raw, origin=os.path.basename(path))
    stem = os.path.splitext(os.path.basename(path))[0]
    if scene.name != stem:
        # outputs are named after the file (results/sim/{file stem}/...); a name: copied from
        # another scene would make two scenes claim one name
        raise SceneError(f"{os.path.basename(path)}: name: {scene.name!r} differs from the file's name "
                         f"{stem!r} (a scene is named by its file: set name: {stem})")
    return scene


def initial_state(scene, n_coordinates):
    """(y0, y'0): scene angles and rates, elastic coordinates at rest."""
    y0 = np.zeros(n_coordinates)
    yd0 = np.zeros(n_coordinates)
    y0[:4] = scene.initial_angles
    yd0[:4] = scene.initial_rates
    return y0, yd0


__all__ = ["Scene", "SceneError", "parse_scene", "load_scene", "initial_state", "math"]

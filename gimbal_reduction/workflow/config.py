"""Load, validate and hash the study's configuration.

Every number in ``config/config.yaml`` is a ``{value, unit, source}`` triple.
:func:`load_config` validates the file against
``gimbal_reduction/workflow/config.schema.yaml`` and against the cross-field rules of
the gimbal model (bearings outside the ring wall, nested bodies that fit), and
raises :class:`ConfigError` with a one-line message naming the culprit key.

Every ``{value, unit}`` entry is read through :func:`gimbal_reduction.workflow.units.convert` into
the unit its key is read in (``UNITS``): a value given in another consistent unit
(``kg/m^3``, ``GPa``, ``rad``) is converted, an unknown unit or one of another
dimension is refused naming the key. The file is read with
:mod:`gimbal_reduction.workflow.yamlfile`, which refuses a duplicate key.

The helpers :func:`value` and :func:`body_parameters` strip units so that the
numerical code receives plain floats. :func:`body_inputs` resolves everything a
body's mesh and modal stages read (the stages read it through this function),
:func:`check_inputs` what each finite-element check reads; :func:`inputs_hash`
of either is the Snakemake rerun trigger of the rule, so a rule reruns when, and
only when, a value its stage reads changes.
"""
from __future__ import annotations

import copy
import fnmatch
import hashlib
import json
import os
from pathlib import Path

import yaml

from gimbal_reduction.workflow import memo, units, yamlfile



def project_dir() -> Path:
    """The project folder (config/, results/, the Snakefile): $GIMBAL_PROJECT if set; else the
    source checkout that holds this package (an editable install, or the tests); else the
    working directory (a package installed from a wheel, run in a project)."""
    given = os.environ.get("GIMBAL_PROJECT")
    if given:
        return Path(given).resolve()
    checkout = Path(__file__).resolve().parents[2]
    if (checkout / "Snakefile").is_file() and (checkout / "config").is_dir():
        return checkout
    return Path.cwd()


ROOT = project_dir()
DEFAULT_CONFIG = ROOT / "config" / "config.yaml"
# the schema ships with the package: the one file contract of the configuration
SCHEMA = Path(__file__).with_name("config.schema.yaml")

BODY_NAMES = ("outer_gimbal", "middle_gimbal", "inner_gimbal", "stable_platform")
BODY_NUMBERS = {name: n for n, name in enumerate(BODY_NAMES, start=2)}


class ConfigError(ValueError):
    """A configuration problem; its message is one line naming the key."""


def _key_path(error: jsonschema.ValidationError) -> str:
    return ".".join(str(p) for p in error.absolute_path) or "<root>"


# The unit each {value, unit} key is read in (gimbal_reduction.workflow.units.convert); a tuple: labels of a
# non-physical unit, given exactly. "*" stands for one key (a body's name).
UNITS = {
    "material.youngs_modulus": "lbf/in^2",
    "material.poissons_ratio": "1",
    "material.density": "lbf*s^2/in^4",
    "bodies.*.diameter": "in",
    "bodies.*.hole_diameter": "in",
    "bodies.*.outer_bearing_distance": "in",
    "bodies.*.inner_bearing_distance": "in",
    "bodies.*.thickness": "in",
    "bodies.*.width": "in",
    "bodies.*.motor_side": ("sign of local x",),
    "eccentric_mass.mass_fraction": "1",
    "eccentric_mass.angle": "deg",
    "eccentric_mass.platform_patch_half_angle": "deg",
    "bearing_connection.platform_patch_half_angle": "deg",
    "bearing_connection.rotation_weight_length": "in",
    "shell.shear_correction": "1",
    "shell.drilling_factor": "1",
    "shell.shear_stabilisation": "1",
    "solid.degree": "1",
    "mesh.ring_size": "in",
    "mesh.platform_size": "in",
    "mesh.refinement_ratio": "1",
    "modes.count": "1",
    "modes.tolerance": "1",
    "modes.max_iterations": "1",
    "verification.free_modes": "1",
    "verification.supported_modes": "1",
    "verification.convergence_modes": "1",
    "simulation.integrator": ("-",),
    "simulation.tolerance": "1",
}


def unit_of(dotted_key: str):
    """The unit (or labels) key ``dotted_key`` is read in, None for a key without one."""
    for pattern, unit in UNITS.items():
        if fnmatch.fnmatchcase(dotted_key, pattern) and dotted_key.count(".") == pattern.count("."):
            return unit
    return None


def resolve_units(config: dict) -> dict:
    """A copy of ``config`` with every ``{value, unit}`` entry in the unit its key is read in.

    An entry given in that unit is kept as it is (the same value, the same unit string);
    a converted one gets the key's unit. Entries of keys without a unit (unknown keys)
    are left for the schema to refuse. ConfigError naming the key for a bad unit.
    """
    out = copy.deepcopy(config)

    def walk(node, path):
        for key, entry in node.items():
            dotted = f"{path}.{key}" if path else str(key)
            if isinstance(entry, dict) and "value" in entry and "unit" in entry:
                expected = unit_of(dotted)
                if expected is None:
                    continue
                try:
                    converted = units.convert(entry, expected, dotted)
                except units.UnitError as exc:
                    raise ConfigError(f"config error at '{exc.key}': {exc.reason}") from None
                if converted is not entry["value"]:
                    entry["value"] = converted
                    entry["unit"] = expected
            elif isinstance(entry, dict):
                walk(entry, dotted)

    if isinstance(out, dict):
        walk(out, "")
    return out


# A configuration that passed is kept with its resolved form between invocations (memo.DiskMemo,
# salted with this file, the schema, the units module and the versions of jsonschema and pint):
# a no-op's DAG build validates an unchanged config without importing jsonschema or pint.
_MEMO = memo.DiskMemo("config", lambda: memo.salt(
    files=(Path(__file__), SCHEMA, Path(units.__file__)), distributions=("jsonschema", "pint")))


def validate(config: dict) -> dict:
    """Check ``config`` against the JSON schema and the model's cross-field rules.

    Returns the config with its values in the units their keys are read in
    (:func:`resolve_units`); ``config`` itself is not changed.
    """
    try:
        key = hashlib.sha256(json.dumps(config, sort_keys=True, allow_nan=False).encode()).hexdigest()
    except (TypeError, ValueError):     # not plain JSON data (the schema refuses it below)
        key = None
    known = _MEMO.get(key) if key else None
    if known is not None:
        return copy.deepcopy(known)
    resolved = _validate(config)
    if key:
        _MEMO.put(key, copy.deepcopy(resolved))
    return resolved


def _validate(config: dict) -> dict:
    import jsonschema      # on first need only (the memo above)
    config = resolve_units(config)
    schema = yamlfile.load_file(SCHEMA)
    validator = jsonschema.Draft7Validator(schema)
    errors = sorted(validator.iter_errors(config), key=lambda e: list(e.absolute_path))
    if errors:
        # the deepest error is the most specific one (e.g. ...thickness.value)
        error = max(errors, key=lambda e: len(e.absolute_path))
        message = error.message
        if error.validator == "additionalProperties":
            message = message.replace("Additional properties are not allowed", "unknown key")
        raise ConfigError(f"config error at '{_key_path(error)}': {message}")
    _check_geometry(config)
    _check_mode_count(config)
    return config


# [1] The fewest modes per body the workflow can run on: the reduction stage builds each body's
# static correction modes against its 10 lowest modes (``gimbal reduce --static-kept``, default 10,
# thesis Section 4.4).
MIN_MODES = 10


def _check_mode_count(config: dict) -> None:
    count = config["modes"]["count"]["value"]
    if count < MIN_MODES:
        raise ConfigError(f"config error at 'modes.count': {count} modes per body, fewer than the "
                          f"{MIN_MODES} the reduction stage keeps for its static correction modes "
                          f"(thesis Section 4.4): set modes.count to at least {MIN_MODES}")


def _check_geometry(config: dict) -> None:
    bodies = config["bodies"]
    for name in BODY_NAMES:
        if bodies[name]["number"] != BODY_NUMBERS[name]:
            raise ConfigError(f"config error at 'bodies.{name}.number': must be {BODY_NUMBERS[name]}")
    for name in BODY_NAMES[:3]:
        b = {k: v["value"] for k, v in bodies[name].items() if isinstance(v, dict)}
        radius, half_t = b["diameter"] / 2, b["thickness"] / 2
        if b["thickness"] >= b["diameter"]:
            raise ConfigError(f"config error at 'bodies.{name}.thickness': wall thicker than the ring's diameter")
        if b["outer_bearing_distance"] / 2 < radius + half_t:
            raise ConfigError(
                f"config error at 'bodies.{name}.outer_bearing_distance': outer bearings "
                f"(radius {b['outer_bearing_distance'] / 2:g} in) lie inside the ring wall "
                f"(outer surface radius {radius + half_t:g} in)")
        if b["inner_bearing_distance"] / 2 > radius - half_t:
            raise ConfigError(
                f"config error at 'bodies.{name}.inner_bearing_distance': inner bearings "
                f"(radius {b['inner_bearing_distance'] / 2:g} in) lie outside the ring's hole "
                f"(inner surface radius {radius - half_t:g} in)")
    plate = {k: v["value"] for k, v in bodies["stable_platform"].items() if isinstance(v, dict)}
    if plate["hole_diameter"] >= plate["diameter"]:
        raise ConfigError("config error at 'bodies.stable_platform.hole_diameter': hole not smaller than the plate")
    if plate["outer_bearing_distance"] / 2 < plate["diameter"] / 2:
        raise ConfigError(
            "config error at 'bodies.stable_platform.outer_bearing_distance': bearings lie inside the "
            f"platform (radius {plate['outer_bearing_distance'] / 2:g} < rim {plate['diameter'] / 2:g} in)")
    # nesting: body n+1 hangs on body n's inner bearings
    for outer, inner in zip(BODY_NAMES[:-1], BODY_NAMES[1:]):
        d_in = bodies[outer]["inner_bearing_distance"]["value"]
        d_out = bodies[inner]["outer_bearing_distance"]["value"]
        if abs(d_in - d_out) > 1e-9:
            raise ConfigError(
                f"config error at 'bodies.{inner}.outer_bearing_distance': {d_out:g} in does not match "
                f"'bodies.{outer}.inner_bearing_distance' {d_in:g} in (the joint is shared)")


def read_config_file(path: str | Path) -> dict:
    """The mapping of a config file, unvalidated; ConfigError for a missing file, invalid YAML
    or a duplicate key (naming the key and the file)."""
    path = Path(path)
    try:
        config = yamlfile.load_file(path)
    except FileNotFoundError:
        raise ConfigError(f"config error: file '{path}' not found") from None
    except yamlfile.DuplicateKeyError as exc:
        raise ConfigError(f"config error at '{exc.key}': duplicate key in '{path}' line {exc.line} "
                          "(the last value would silently win)") from None
    except yamlfile.YAMLInputError as exc:
        raise ConfigError(f"config error: {exc}") from None
    except yaml.YAMLError as exc:
        line = getattr(getattr(exc, "problem_mark", None), "line", None)
        where = f" line {line + 1}" if line is not None else ""
        raise ConfigError(f"config error: '{path}'{where} is not valid YAML") from None
    if not isinstance(config, dict):
        raise ConfigError(f"config error: '{path}' does not hold a mapping")
    return config


_VALIDATED: dict = {}


def load_config(path: str | Path = DEFAULT_CONFIG) -> dict:
    """Read and validate a config file; raise ConfigError with a one-line message.

    The values come in the units their keys are read in (:func:`validate`).  A file validated
    before in this process (same path, size and modification time, same schema file) is not
    validated again: its result is handed out as a deep copy (a study process loads the config
    ~150 times; the JSON-schema check and the unit conversions cost ~30 ms each)."""
    try:
        key = (yamlfile.file_key(path), yamlfile.file_key(SCHEMA))
    except OSError:
        key = None                          # read_config_file gives the one-line error
    if key is None or key not in _VALIDATED:
        config = validate(read_config_file(path))
        if key is None:
            return config
        if len(_VALIDATED) >= 16:
            _VALIDATED.clear()
        _VALIDATED[key] = config
    return copy.deepcopy(_VALIDATED[key])


def value(config: dict, dotted_key: str):
    """The plain value of ``a.b.c`` (unit and source stripped)."""
    node = config
    for part in dotted_key.split("."):
        node = node[part]
    return node["value"] if isinstance(node, dict) and "value" in node else node


def body_name(body: int | str) -> str:
    """Body name from its number (2..5) or name; one-line error otherwise."""
    if isinstance(body, str) and body in BODY_NUMBERS:
        return body
    try:
        number = int(body)
    except (TypeError, ValueError):
        number = None
    for name, n in BODY_NUMBERS.items():
        if n == number:
            return name
    raise ConfigError(f"unknown body '{body}': expected 2..5 or one of {', '.join(BODY_NAMES)}")


def body_parameters(config: dict, body: int | str) -> dict:
    """Flat, unit-stripped parameters of one body, with material and connection data.

    Returns a dict with the body's own keys (``diameter``, ``thickness`` ...),
    ``name``, ``number``, ``model`` (``shell`` or ``solid``), the material
    constants and the next body's motor side (``output_motor_side``: the sign
    of local z at which this body's output motor sits).
    """
    name = body_name(body)
    raw = config["bodies"][name]
    params = {k: (v["value"] if isinstance(v, dict) else v) for k, v in raw.items()}
    params["name"] = name
    params.setdefault("model", "shell" if raw["shape"] == "ring" else "solid")
    params.update({k: v["value"] for k, v in config["material"].items()})
    index = BODY_NAMES.index(name)
    if index + 1 < len(BODY_NAMES):
        # body n+1's local x is body n's local z, so its motor at x_{n+1} = s sits at z_n = s
        params["output_motor_side"] = config["bodies"][BODY_NAMES[index + 1]]["motor_side"]["value"]
    return params


def inputs_hash(inputs) -> str:
    """Stable 12-hex-digit hash of a JSON-able object (resolved stage inputs, config sections)."""
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def section_hash(config: dict, *dotted_keys: str) -> str:
    """Stable 12-hex-digit hash of the named config sections (all of it if none)."""
    if dotted_keys:
        parts = {}
        for key in dotted_keys:
            node = config
            for part in key.split("."):
                node = node[part]
            parts[key] = node
    else:
        parts = config
    return inputs_hash(parts)


# the body parameters that shape a body's mesh: the regions sit at the motor and mass angles
MESH_KEYS = {"ring": ("name", "shape", "diameter", "width", "motor_side", "output_motor_side"),
             "plate": ("name", "shape", "diameter", "hole_diameter", "thickness", "motor_side")}


def _pick(params: dict, keys) -> dict:
    return {k: params[k] for k in keys if k in params}


def body_inputs(config: dict, body: int | str, mesh_size: float | None = None) -> dict:
    """Everything a body's mesh and modes read, resolved to plain values.

    ``mesh``: what ``gimbal_reduction.geometry.mesh`` reads: the body's shape parameters and motor
    sides (its own and, for a ring, the next body's, which places the output
    bearings), the mesh size (``mesh_size`` overrides the config's), the mass angle
    and, for the platform, the rim-patch half-angles. The rest is what
    ``gimbal_reduction.solver.fe.modes`` reads: the body parameters with material
    (:func:`body_parameters`, without ``number``, which the stage takes from its
    caller), the eccentric mass, the connection's rotation weight, the shell
    settings or the solid's degree (by the body's model), and the eigen-solve settings.
    """
    params = body_parameters(config, body)
    params.pop("number", None)
    ring = params["shape"] == "ring"
    size = mesh_size if mesh_size is not None else value(config, "mesh.ring_size" if ring else "mesh.platform_size")
    mesh = {"body": _pick(params, MESH_KEYS["ring" if ring else "plate"]), "size": size,
            "mass_angle": value(config, "eccentric_mass.angle")}
    if not ring:
        mesh["bearing_half_angle"] = value(config, "bearing_connection.platform_patch_half_angle")
        mesh["mass_half_angle"] = value(config, "eccentric_mass.platform_patch_half_angle")
    inputs = {"mesh": mesh, "body": params,
              "mass_angle": value(config, "eccentric_mass.angle"),
              "mass_fraction": value(config, "eccentric_mass.mass_fraction"),
              "rotation_weight_length": value(config, "bearing_connection.rotation_weight_length"),
              "modes": {k: value(config, f"modes.{k}") for k in ("count", "tolerance", "max_iterations")}}
    if params["model"] == "shell":
        inputs["shell"] = shell_settings(config)
    else:
        inputs["solid_degree"] = int(value(config, "solid.degree"))
    return inputs


def shell_settings(config: dict) -> dict:
    """The shell model's settings (``shell`` section), unit-stripped."""
    return {k: v["value"] for k, v in config["shell"].items()}


def _without(inputs: dict, *keys: str) -> dict:
    """``inputs`` less the dotted ``keys`` (a copy)."""
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in inputs.items()}
    for key in keys:
        head, _, tail = key.partition(".")
        if tail:
            out[head].pop(tail, None)
        else:
            out.pop(head, None)
    return out


# what each FE verification check of ``gimbal_reduction.solver.fe.checks`` reads (``gimbal_reduction.solver.fe.verify CHECK``)
CHECKS = ("ring", "plate", "solid-ring", "platform", "convergence", "body-file", "hughes", "mpi", "connection",
          "spectra")


def check_inputs(config: dict, check: str, body: int | str | None = None) -> dict:
    """The resolved config values that an FE verification check reads (its rule's rerun trigger)."""
    material = {k: v["value"] for k, v in config["material"].items()}
    if check in ("ring", "solid-ring"):         # bare free ring of body 2, shell (and solid)
        ring = body_parameters(config, 2)
        out = {"ring": _pick(ring, ("name", "model", "diameter", "thickness", "width")), "material": material,
               "shell": shell_settings(config), "size": value(config, "mesh.ring_size")}
        if check == "solid-ring":
            out["solid_degree"] = int(value(config, "solid.degree"))
        return out
    if check == "plate":                         # NAFEMS FV12: its own plate and material
        return {"shell": shell_settings(config)}
    if check == "platform":                      # the platform free-free, as a solid and as a shell
        return {"mesh": body_inputs(config, 5)["mesh"], "model": body_parameters(config, 5)["model"],
                "material": material, "shell": shell_settings(config),
                "solid_degree": int(value(config, "solid.degree"))}
    if check == "hughes":                        # the coarse body file of body 4 alone (its input: the file
        return {}                                # carries its config hash, and coarse_body_all_modes reruns)
    if check == "connection":                    # body 2 at two mesh levels, assembled
        return {"body": _without(body_inputs(config, 2), "modes"),
                "refinement_ratio": value(config, "mesh.refinement_ratio")}
    if check == "convergence":                   # three mesh levels of one body
        return {"body": _without(body_inputs(config, body), "modes.count"),
                "refinement_ratio": value(config, "mesh.refinement_ratio"),
                "count": value(config, "verification.convergence_modes"),
                "reported": value(config, "modes.count")}     # every study mode's deviation reported
    if check == "mpi":                           # the modal stage of body 2 (mode count from its body file)
        return _without(body_inputs(config, 2), "modes.count")
    if check == "body-file":                     # residuals and orthonormality from the body file alone
        return {}
    if check == "spectra":
        return {k: value(config, f"verification.{k}") for k in ("free_modes", "supported_modes")}
    raise ConfigError(f"unknown check '{check}': choose from {', '.join(CHECKS)}")

"""Units of every ``{value, unit}`` entry of the project's YAML files, read through pint.

The project computes in inch, pound-force and second (mass in lbf*s^2/in). Each key
states the unit its code reads (``lbf/in^2``, ``lbf*s^2/in^4``, ``in``, ``deg``,
``rad/s``, ``Hz``, ``1`` ...); :func:`convert` returns an entry's value in that unit,
whatever consistent unit the file gives it in, and refuses an unknown unit or one of
another dimension with a one-line :class:`UnitError` naming the key.

The registry is the project's own (``DEFINITIONS``), not pint's default one, so that:

* an angle is a dimension of its own: ``deg`` and ``rad`` convert into each other,
  but neither passes for a dimensionless key (a Poisson's ratio in degrees is refused);
* ``Hz`` is a cycle per second, a cycle being 2 pi rad: 1 Hz is 2 pi rad/s, and ``1/s``
  (which says neither cycles nor radians) is refused where a frequency is read;
* ``lb`` is the pound mass and ``lbf`` the pound-force (g0 = 9.80665 m/s^2, exact), so
  ``slug/in^3``, ``kg/m^3`` and ``lbf*s^2/in^4`` are the same dimension.

A unit may carry a note in parentheses after a space (``"1 (of structural mass)"``,
``"deg (from +x towards +z)"``): when the whole string is not a unit expression, the
trailing note is dropped. Non-physical labels (``"sign of local x"``, ``"body number"``)
are matched exactly, from an explicit tuple the caller gives instead of a unit.

What pint answers for a pair (unit given, unit expected) (the same unit, or the factor between
them) is kept between invocations (:class:`gimbal_reduction.workflow.memo.DiskMemo`, salted with
this file, ``DEFINITIONS`` and pint's version): a workflow run that reads only known pairs, a
no-op's DAG build, neither imports pint nor builds the registry. A refused unit is never kept.
"""
from __future__ import annotations

import functools
import math
import re
from numbers import Real
from pathlib import Path

from gimbal_reduction.workflow import memo

# The project's units (pint definition syntax). Exact definitions: 1 in = 0.0254 m,
# 1 lb = 0.45359237 kg, g0 = 9.80665 m/s^2.
DEFINITIONS = f"""
pi = {math.pi!r} = π
nano- = 1e-9 = n-
micro- = 1e-6 = u- = µ-
milli- = 1e-3 = m-
centi- = 1e-2 = c-
kilo- = 1e3 = k-
mega- = 1e6 = M-
giga- = 1e9 = G-
meter = [length] = m = metre
second = [time] = s = sec
gram = [mass] = g
radian = [angle] = rad
inch = 0.0254 * meter = in
foot = 12 * inch = ft
yard = 3 * foot = yd
mile = 5280 * foot = mi
minute = 60 * second = min
hour = 60 * minute = h = hr
degree = pi / 180 * radian = deg
turn = 2 * pi * radian = rev = revolution = cycle
hertz = turn / second = Hz
rpm = turn / minute
pound = 0.45359237 * kilogram = lb = lbm
standard_gravity = 9.80665 * meter / second ** 2 = g0
pound_force = pound * standard_gravity = lbf
kip = 1000 * pound_force
newton = kilogram * meter / second ** 2 = N
slug = pound_force * second ** 2 / foot
pascal = newton / meter ** 2 = Pa
psi = pound_force / inch ** 2
ksi = 1000 * psi
percent = 0.01 = %
"""

# names of the dimensions the project reads, for the messages (exponents of pint's base dimensions)
_L, _T, _M, _A = "[length]", "[time]", "[mass]", "[angle]"
_DIMENSION_NAMES = (
    ({}, "dimensionless"), ({_L: 1}, "a length"), ({_T: 1}, "a time"), ({_M: 1}, "a mass"),
    ({_A: 1}, "an angle"), ({_A: 1, _T: -1}, "an angular velocity or frequency"),
    ({_A: 1, _T: -2}, "an angular acceleration"), ({_A: 2, _T: -2}, "an angular velocity squared"),
    ({_T: -1}, "1/time"), ({_M: 1, _L: 1, _T: -2}, "a force"),
    ({_M: 1, _L: 2, _T: -2}, "a torque (force*length)"), ({_M: 1, _L: -1, _T: -2}, "a pressure (force/area)"),
    ({_M: 1, _L: -3}, "a density (mass/volume)"),
)

_NOTE = re.compile(r"^(?P<unit>.*\S)\s+\((?P<note>[^()]*)\)\s*$")


class UnitError(ValueError):
    """A unit that cannot be read for a key: ``key`` and ``reason``; str() is one line naming the key."""

    def __init__(self, key: str, reason: str):
        super().__init__(f"{key}: {reason}")
        self.key, self.reason = key, reason


@functools.lru_cache(maxsize=1)
def registry():
    """The project's unit registry (a ``pint.UnitRegistry``, built once; pint is imported here,
    on first need: see the module docstring)."""
    import pint
    reg = pint.UnitRegistry(None, autoconvert_offset_to_baseunit=False)
    for line in DEFINITIONS.strip().splitlines():
        reg.define(line)
    return reg


def _parse(text: str):
    reg = registry()
    try:
        quantity = reg.parse_expression(text)
    except Exception:  # noqa: BLE001 - pint raises several kinds (undefined name, syntax)
        return None
    if isinstance(quantity, Real) and not isinstance(quantity, bool):
        quantity = reg.Quantity(quantity)
    return quantity if isinstance(quantity, reg.Quantity) else None


@functools.lru_cache(maxsize=256)
def quantity(unit: str):
    """The pint quantity (factor and units) a unit string means, or None if it is not a unit.

    The whole string is tried first, then the string without a trailing ``(note)``.
    """
    if not isinstance(unit, str) or not unit.strip():
        return None
    parsed = _parse(unit)
    if parsed is None:
        match = _NOTE.match(unit)
        if match:
            parsed = _parse(match.group("unit"))
    if parsed is None or not math.isfinite(parsed.magnitude) or parsed.magnitude == 0:
        return None
    return parsed


def describe(dimensionality) -> str:
    """A dimension in words (pint's form when the project has no name for it)."""
    exponents = dict(dimensionality)
    for known, name in _DIMENSION_NAMES:
        if exponents == known:
            return name
    return str(dimensionality)


def _is_number(x) -> bool:
    return isinstance(x, Real) and not isinstance(x, bool)


def convert(entry: dict, expected, key: str):
    """The value of a ``{value, unit, ...}`` entry in the unit ``expected`` that key ``key`` is read in.

    ``expected`` is a unit expression of the project's registry (``"lbf*s^2/in^4"``, ``"deg"``,
    ``"Hz"``, ``"1"``), or a tuple of labels for a non-physical unit (``("sign of local x",)``),
    which must then be given exactly. A value given in the expected unit is returned as it
    is (the same object: bit-identical, an int stays an int); another unit of the same
    dimension is converted (a scalar or each element of a list). A value that is not a
    number (or list of numbers) is returned unconverted, for the caller's type checks.

    Raises :class:`UnitError` naming ``key`` for a missing, unknown or non-physical unit,
    or a unit of another dimension than ``expected``'s.
    """
    unit = entry.get("unit") if isinstance(entry, dict) else None
    value = entry.get("value") if isinstance(entry, dict) else None
    if isinstance(expected, tuple):
        if unit not in expected:
            labels = " or ".join(repr(e) for e in expected)
            raise UnitError(key, f"unit must be {labels} (a label, not a physical unit), got {unit!r}")
        return value
    if not isinstance(unit, str) or not unit.strip():
        raise UnitError(key, f"no unit given (expected {expected})")
    factor = _factor(unit, expected, key)
    if factor is None:
        return value
    if _is_number(value):
        return value * factor
    if isinstance(value, list) and all(_is_number(v) for v in value):
        return [v * factor for v in value]
    return value


# (unit given, unit expected) -> "same", or the factor from the first to the second (module docstring)
_MEMO = memo.DiskMemo("units", lambda: memo.salt(DEFINITIONS, files=(Path(__file__),),
                                                 distributions=("pint",)))


def _factor(unit: str, expected: str, key: str):
    """The factor that takes a value in ``unit`` to ``expected``, None when they are the same
    unit; UnitError naming ``key`` for an unknown unit or one of another dimension."""
    pair = f"{unit}\n{expected}"
    known = _MEMO.get(pair)
    if known is not None:
        return None if known == "same" else float(known)
    target = quantity(expected)
    if target is None:
        raise ValueError(f"{key}: the expected unit {expected!r} is not in the project's registry")
    given = quantity(unit)
    if given is None:
        raise UnitError(key, f"unknown unit {unit!r} (expected {describe(target.dimensionality)}, "
                             f"e.g. {expected})")
    if given.dimensionality != target.dimensionality:
        hint = ""
        if set((given.dimensionality / target.dimensionality).keys()) == {"[angle]"}:
            hint = "; an angle is a unit here (a cycle is 2 pi rad): write Hz or rad/s, deg or rad"
        raise UnitError(key, f"unit {unit!r} is {describe(given.dimensionality)}, expected "
                             f"{describe(target.dimensionality)} ({expected}){hint}")
    if given.units == target.units and given.magnitude == target.magnitude:
        _MEMO.put(pair, "same")
        return None
    factor = float((given / target).to("dimensionless").magnitude)
    _MEMO.put(pair, factor)
    return factor


__all__ = ["DEFINITIONS", "UnitError", "convert", "describe", "quantity", "registry"]

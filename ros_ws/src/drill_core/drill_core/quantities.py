"""Values with units in configuration and scenario files ("685 bar", "10.5 ppg",
"1200 L/min"), converted to the SI unit a field declares (drill_core.schema) at load;
pint does the arithmetic. The oilfield units pint lacks or names otherwise: ``ppg``
(pound per US gallon), ``gpm`` (US gallon per minute), ``bbl`` (the oil barrel, 42 US
gallons: pint's own is the 31.5-gallon liquid barrel) and ``sg`` (specific gravity,
1000 kg/m^3, the drilling convention)."""
from __future__ import annotations

import warnings
from functools import lru_cache

EXTRA_UNITS = ("ppg = pound / gallon", "gpm = gallon / minute", "bbl = 42 * gallon",
               "sg = 1000 * kilogram / meter ** 3 = s.g.")


@lru_cache(maxsize=1)
def _registry():
    import pint               # only when a file writes a unit: a second to import
    registry = pint.UnitRegistry(on_redefinition="warn")
    with warnings.catch_warnings():          # bbl: the oil barrel replaces pint's
        warnings.simplefilter("ignore")
        for definition in EXTRA_UNITS:
            registry.define(definition)
    return registry


def to_si(text: str, unit: str) -> float:
    """``text`` (a number and a unit) in ``unit`` (the field's SI unit); ValueError that
    says why when it is not a quantity or not of that dimension."""
    import pint
    registry = _registry()
    failures = (pint.errors.PintError, ValueError, TypeError, AttributeError, SyntaxError)
    try:
        target = registry.Unit(unit)
    except failures as err:
        raise ValueError(f"a unit cannot be written here (the field's unit {unit!r} is not "
                         f"one pint knows); give the number in {unit}") from err
    try:
        quantity = registry.Quantity(text)
    except failures as err:
        raise ValueError(f"{text!r} is not a number with a unit (e.g. '685 bar')") from err
    if quantity.dimensionless and not target.dimensionless:
        raise ValueError(f"{text!r} has no unit; write it with one, e.g. '1.5 {unit}'")
    try:
        return float(quantity.to(target).magnitude)
    except pint.errors.DimensionalityError as err:
        raise ValueError(f"{text!r} is not a quantity of {unit} ({err.dim1} vs {err.dim2})") \
            from err

"""Typed, immutable configuration objects built from YAML mappings.

A configuration class is a frozen dataclass whose fields are declared with
:func:`param`, giving each value its unit and allowed range. :func:`build`
turns a mapping into such an object and refuses bad input with a
:class:`ConfigError` that names the file, the key, the value and what is allowed.
A number with a unit may be written as text (``685 bar``, ``10.5 ppg``), also under the
key without its unit suffix (``bhp_ref: 685 bar`` for ``bhp_ref_pa``): converted to the
field's SI unit at load (drill_core.quantities).
"""
from __future__ import annotations

import dataclasses
import math
import types
import typing
from typing import Any, Mapping

from drill_core.quantities import to_si


class ConfigError(ValueError):
    """Bad configuration input; the message names file, key, value and the allowed range."""


class FieldError(ValueError):
    """Raised by a ``validate()`` method about one key: ``key`` is its path relative to the
    object being validated (e.g. ``"string[2].outer_diameter_m"``), so the resulting
    :class:`ConfigError` names the full key path."""

    def __init__(self, key: str, message: str):
        super().__init__(message)
        self.key = key


def param(unit: str = "", lo: float | None = None, hi: float | None = None, *,
          lo_open: bool = False, choices: tuple[str, ...] | None = None,
          default: Any = dataclasses.MISSING, doc: str = "") -> Any:
    """Declare a configuration field with its SI unit and allowed range [lo, hi]."""
    meta = {"unit": unit, "lo": lo, "hi": hi, "lo_open": lo_open, "choices": choices, "doc": doc}
    if isinstance(default, (list, dict)):
        raise TypeError("mutable defaults are not allowed")
    return dataclasses.field(default=default, metadata=meta)


def range_text(meta: Mapping[str, Any]) -> str:
    """'[lo, hi] unit' of a field's metadata (lo, hi, lo_open, unit; unit '1': none)."""
    lo, hi = meta.get("lo"), meta.get("hi")
    left = "(" if meta.get("lo_open") else "["
    lo_s = "-inf" if lo is None else f"{lo:g}"
    hi_s = "inf" if hi is None else f"{hi:g}"
    unit = f" {meta['unit']}" if meta.get("unit") not in (None, "", "1") else ""  # "1": none
    return f"{left}{lo_s}, {hi_s}]{unit}"


def _optional_inner(hint: Any) -> Any:
    """``X`` for a hint ``X | None`` (a field that may be left unset), else None."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        inner = [a for a in typing.get_args(hint) if a is not type(None)]
        if len(inner) == 1:
            return inner[0]
    return None


def _allowed_text(hint: Any, meta: Mapping[str, Any]) -> str:
    """What a field accepts, for error messages."""
    inner = _optional_inner(hint)
    if inner is not None:
        return f"{_allowed_text(inner, meta)} (or null: unset)"
    if dataclasses.is_dataclass(hint):
        return f"a mapping with keys {', '.join(f.name for f in dataclasses.fields(hint) if f.init)}"
    if typing.get_origin(hint) is tuple:
        return f"a non-empty list, each item {_allowed_text(typing.get_args(hint)[0], meta)}"
    if hint is bool:
        return "true or false"
    if hint is str:
        choices = meta.get("choices")
        return f"one of {', '.join(choices)}" if choices else "a string"
    kind = "an integer" if hint is int else "a number"
    return f"{kind} in {range_text(meta)}"


class _Where:
    """Location of a value: file and dotted key path, for error messages."""

    def __init__(self, source: str, path: str = ""):
        self.source, self.path = source, path

    def child(self, key: Any) -> "_Where":
        key_s = f"[{key}]" if isinstance(key, int) else str(key)
        sep = "" if not self.path or isinstance(key, int) else "."
        return _Where(self.source, f"{self.path}{sep}{key_s}")

    def at(self, relative: str) -> "_Where":
        """The location ``relative`` (a dotted key path, may start with ``[i]``) below this one."""
        if not relative:
            return self
        sep = "" if not self.path or relative.startswith("[") else "."
        return _Where(self.source, f"{self.path}{sep}{relative}")

    def fail(self, message: str) -> ConfigError:
        return ConfigError(f"{self.source}: {self.path or '<top>'}: {message}")


def _check_number(value: Any, meta: Mapping[str, Any], where: _Where, integer: bool) -> float | int:
    written = value
    if isinstance(value, str) and not integer and meta.get("unit"):
        try:                                 # "685 bar": to the field's SI unit
            value = to_si(value, meta["unit"])
        except ValueError as err:
            raise where.fail(f"value {value!r} must be a number in {range_text(meta)} or a "
                             f"quantity of that unit: {err}") from None
        written = f"{written!r} ({value:g} {meta['unit']})"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        kind = "an integer" if integer else "a number"
        raise where.fail(f"value {value!r} must be {kind} in {range_text(meta)}")
    if integer and not float(value).is_integer():
        raise where.fail(f"value {value!r} must be an integer in {range_text(meta)}")
    number = int(value) if integer else float(value)
    lo, hi = meta.get("lo"), meta.get("hi")
    bad = (not math.isfinite(number)
           or (lo is not None and (number <= lo if meta.get("lo_open") else number < lo))
           or (hi is not None and number > hi))
    if bad:
        shown = written if isinstance(written, str) else repr(value)
        raise where.fail(f"value {shown} is outside the allowed range {range_text(meta)}")
    return number


def _convert(value: Any, hint: Any, meta: Mapping[str, Any], where: _Where) -> Any:
    inner = _optional_inner(hint)
    if inner is not None:
        return None if value is None else _convert(value, inner, meta, where)
    origin = typing.get_origin(hint)
    if dataclasses.is_dataclass(hint):
        return build(hint, value, where.source, where.path)
    if origin is tuple:
        item_hint = typing.get_args(hint)[0]
        if not isinstance(value, (list, tuple)) or len(value) == 0:
            raise where.fail(f"value {value!r} must be {_allowed_text(hint, meta)}")
        return tuple(_convert(v, item_hint, meta, where.child(i)) for i, v in enumerate(value))
    if hint is float:
        return _check_number(value, meta, where, integer=False)
    if hint is int:
        return _check_number(value, meta, where, integer=True)
    if hint is bool:
        if not isinstance(value, bool):
            raise where.fail(f"value {value!r} must be true or false")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise where.fail(f"value {value!r} must be {_allowed_text(hint, meta)}")
        choices = meta.get("choices")
        if choices and value not in choices:
            raise where.fail(f"value {value!r} is not one of {', '.join(choices)}")
        return value
    raise TypeError(f"unsupported configuration type {hint!r}")


def _unit_keys(data: Mapping, fields: Mapping[str, dataclasses.Field], where: _Where) -> Mapping:
    """``data`` with a key written without its field's unit suffix (``bhp_ref: 685 bar``
    for ``bhp_ref_pa``) under the field's name; such a key takes a value with a unit."""
    out = dict(data)
    for key in [k for k in data if isinstance(k, str) and k not in fields]:
        named = [f for f in fields if f.startswith(key + "_") and fields[f].metadata.get("unit")
                 and f[len(key) + 1:].isalnum() and f[len(key) + 1:].islower()]
        if len(named) != 1 or named[0] in data:
            continue
        if not isinstance(data[key], str):
            raise where.child(key).fail(
                f"value {data[key]!r} needs its unit (e.g. '{data[key]} {fields[named[0]].metadata['unit']}'), "
                f"or write the key as {named[0]} in {fields[named[0]].metadata['unit']}")
        out[named[0]] = out.pop(key)
    return out


def build(cls: type, data: Any, source: str = "<memory>", path: str = "") -> Any:
    """Build the frozen dataclass ``cls`` from ``data``, checking keys, types and ranges."""
    where = _Where(source, path)
    if not isinstance(data, Mapping):
        raise where.fail(f"expected a mapping of keys for {cls.__name__}, got {data!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    data = _unit_keys(data, fields, where)
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise where.fail(f"unknown key(s) {', '.join(map(str, unknown))}; allowed: {', '.join(fields)}")
    values = {}
    for name, field in fields.items():
        if name not in data:
            if field.default is dataclasses.MISSING:
                raise where.child(name).fail(
                    f"missing key (allowed: {_allowed_text(hints[name], field.metadata)})")
            continue
        values[name] = _convert(data[name], hints[name], field.metadata, where.child(name))
    obj = cls(**values)
    check = getattr(obj, "validate", None)
    if check is not None:
        try:
            check()
        except ValueError as err:
            raise where.at(getattr(err, "key", "")).fail(str(err)) from None
    return obj

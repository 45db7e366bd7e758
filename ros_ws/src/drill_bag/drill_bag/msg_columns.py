"""Message definitions as table columns: a recorded ``ros2msg`` schema (the dependency-
expanded text an MCAP file carries) parsed into fields, each named with its SI unit from
the field's comment, and messages flattened into rows of those columns.

Plain Python (no rclpy). The unit of a field is the one bracketed unit in its comment
(``float64 choke_opening  # choke opening u_c [1]``); a name that already ends in it
(``bhp_pa`` for ``[Pa]``, ``string_velocity_mps`` for ``[m/s]``) is kept, any other gets
``_<unit>`` appended (``choke_opening_1``: ``1`` is the SI unit of a dimensionless
quantity). A comment with no bracketed unit or with two different units leaves the name as
it is; a ``[unit]`` placeholder says the unit is in the message's ``unit`` field
(ActuatorFrame), which the export appends when it is the same in every message. Nested messages are
flattened with dots (``clock.sec``), array elements get their index (``output[3]``).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from drill_bag.mcap_io import DELIMITER, HEADER_TYPES, PRIMITIVE_TYPES

UNIT_PATTERN = re.compile(r"\[([A-Za-z0-9^/ .]+)\]")
PLACEHOLDER_UNITS = frozenset({"unit"})
FLOAT_TYPES = frozenset({"float32", "float64"})
INT_TYPES = frozenset({"byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
                       "int64", "uint64"})


@dataclass(frozen=True)
class Field:
    """One field of a message type: its ROS type ('float64', 'pkg/Type'), name, whether it
    is an array, and the SI unit its comment gives ('' when none)."""

    type_name: str
    name: str
    is_array: bool
    unit: str

    @property
    def column(self) -> str:
        """The field's column name: its name, with the unit appended if it lacks it."""
        if not self.unit or self.unit in PLACEHOLDER_UNITS or names_unit(self.name, self.unit):
            return self.name
        return f"{self.name}_{unit_token(self.unit)}"

    @property
    def primitive(self) -> bool:
        return self.type_name in PRIMITIVE_TYPES


def unit_spellings(unit: str) -> set[str]:
    """How a field name may spell ``unit`` at its end: 'm^3/s' -> m3s, m3ps, m3_s."""
    compact = unit.lower().replace("^", "").replace(".", "")
    out = set()
    for space in ("", "_"):
        for per in ("", "p", "_"):
            out.add(compact.replace(" ", space).replace("/", per))
    return out


def unit_token(unit: str) -> str:
    """The suffix appended for ``unit``, as the rig's names spell units: lower case, no
    '^' or spaces, '/' dropped after a digit and 'p' (per) after a letter ('m^3/s' -> m3s,
    'm/s' -> mps)."""
    compact = unit.lower().replace("^", "").replace(".", "").replace(" ", "")
    return re.sub(r"(?<=[0-9])/", "", compact).replace("/", "p")


def names_unit(name: str, unit: str) -> bool:
    """True when the field name already ends in a spelling of ``unit``."""
    return any(name.lower().endswith("_" + s) for s in unit_spellings(unit))


def comment_unit(comment: str) -> str:
    """The SI unit a field comment gives: its one distinct bracketed unit ('unit': the
    placeholder), else ''."""
    units = {u.strip() for u in UNIT_PATTERN.findall(comment)}
    if len(units) != 1:
        return ""
    return units.pop()


def _qualified(type_name: str, package: str) -> str:
    """'Header' in package std_msgs -> 'std_msgs/Header'; 'pkg/msg/T' -> 'pkg/T'."""
    if type_name in PRIMITIVE_TYPES:
        return type_name
    parts = type_name.split("/")
    if len(parts) == 1:
        return f"{package}/{type_name}"
    return f"{parts[0]}/{parts[-1]}"


def _fields(text: str, package: str) -> list[Field]:
    fields = []
    for line in text.splitlines():
        code, _, comment = line.partition("#")
        tokens = code.split()
        if len(tokens) < 2 or "=" in code:
            continue                                     # blank, comment or a constant
        type_text, name = tokens[0], tokens[1]
        is_array = "[" in type_text
        base = re.split(r"[\[<]", type_text, maxsplit=1)[0]
        fields.append(Field(_qualified(base, package), name, is_array, comment_unit(comment)))
    return fields


def parse_definition(type_name: str, definition: str) -> dict[str, list[Field]]:
    """Fields of every type in a dependency-expanded definition, by 'pkg/Type' (the
    top-level type under ``type_name``)."""
    sections = definition.split(DELIMITER)
    top = _qualified(type_name, "")
    types = {top: _fields(sections[0], top.split("/")[0])}
    for section in sections[1:]:
        body = section.strip("\n")
        first, _, rest = body.partition("\n")
        if not first.startswith("MSG: "):
            continue
        name = _qualified(first[len("MSG: "):].strip(), "")
        types[name] = _fields(rest, name.split("/")[0])
    return types


@dataclass(frozen=True)
class Layout:
    """How a message type becomes a row: its parsed types and whether it has a header
    (whose stamp is the row's time and which is left out of the columns)."""

    top: str
    types: dict
    has_header: bool

    @classmethod
    def of(cls, type_name: str, definition: str) -> Layout:
        types = parse_definition(type_name, definition)
        top = _qualified(type_name, "")
        fields = types[top]
        return cls(top, types, bool(fields) and fields[0].type_name in HEADER_TYPES)

    @property
    def placeholder_columns(self) -> frozenset[str]:
        """Top-level columns whose unit is in the message's ``unit`` field."""
        return frozenset(f.column for f in self.types[self.top] if f.unit in PLACEHOLDER_UNITS)

    def row(self, message) -> dict:
        """Column -> value of one decoded message (mcap_ros2 dynamic object)."""
        out: dict = {}
        fields = self.types[self.top][1:] if self.has_header else self.types[self.top]
        self._flatten(message, fields, "", out)
        return out

    def kind(self, column: str) -> str:
        """'float', 'int', 'uint64', 'bool' or 'string' of a column this layout makes."""
        fields = self.types[self.top]
        kind = ""
        for part in column.split("."):
            name = part.split("[", 1)[0]
            field = next(f for f in fields if f.column == name)
            if field.primitive:
                kind = field.type_name
            else:
                fields = self.types[field.type_name]
        if kind in FLOAT_TYPES:
            return "float"
        if kind == "uint64":
            return "uint64"
        if kind in INT_TYPES:
            return "int"
        return "bool" if kind == "bool" else "string"

    def unit(self, column: str) -> str:
        """The SI unit of a column this layout makes, from its field's comment ('' when
        none; a placeholder such as 'unit' when the message's ``unit`` field gives it)."""
        fields, unit = self.types[self.top], ""
        for part in column.split("."):
            field = next(f for f in fields if f.column == part.split("[", 1)[0])
            unit = field.unit
            if not field.primitive:
                fields = self.types[field.type_name]
        return unit

    def _flatten(self, value, fields: list[Field], prefix: str, out: dict) -> None:
        for f in fields:
            name = prefix + f.column
            item = getattr(value, f.name)
            if f.is_array:
                for i, element in enumerate(item):
                    self._put(element, f, f"{name}[{i}]", out)
            else:
                self._put(item, f, name, out)

    def _put(self, item, f: Field, name: str, out: dict) -> None:
        if f.primitive:
            out[name] = item
        else:
            self._flatten(item, self.types[f.type_name], name + ".", out)

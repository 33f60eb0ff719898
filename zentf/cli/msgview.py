"""How `zentf topic echo` shows a message: YAML, CSV or JSON, with ros2 topic echo's `--field`, `--no-arr`,
`--no-str` and `--truncate-length`, driven by the ROS definition of the type (zentf.ros) where it has one.

The shapes are ROS 2's (rosidl_runtime_py's message_to_yaml / message_to_csv): an array left out is
``<sequence type: T, length: N>`` (``<array type: T[N]>`` for a fixed one, ``<sequence type: T[B], length: N>``
for a bounded one), a string left out ``<string length: <N>>``, a truncated array or string ends in ``...``.
"""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from typing import Any, Optional

__all__ = ["View", "parse_field", "field_type", "FieldError"]

#: ros2 topic echo's default --truncate-length.
DEFAULT_TRUNCATE = 128


class FieldError(ValueError):
    """A --field path that the message (or its type) does not have."""


def parse_field(text: Optional[str]) -> Optional[list[str]]:
    """'pose.position' -> ['pose', 'position'] (empty parts dropped, as ros2 does); None for no --field."""
    if text is None:
        return None
    parts = [p for p in text.split(".") if p]
    if not parts:
        raise FieldError(f"invalid field value {text!r}")
    return parts


def _definition(type_name: Optional[str]) -> Any:
    if not type_name:
        return None
    from zentf.ros import UnknownTypeError, definition

    try:
        return definition(type_name)
    except UnknownTypeError:
        return None


def field_type(type_name: str, path: list[str]) -> None:
    """FieldError unless ``path`` names a field of ``type_name``, nested message by nested message (checked
    before anything is received, when the type is known)."""
    current = type_name
    for i, name in enumerate(path):
        d = _definition(current)
        if d is None:
            return  # no definition to check against: the first message will tell
        f = next((f for f in d.fields if f.name == name), None)
        if f is None:
            fields = ", ".join(f.name for f in d.fields)
            raise FieldError(f"invalid field {'.'.join(path)!r}: {current} has no field {name!r} (fields: {fields})")
        if i + 1 < len(path) and (not f.nested or f.array is not None):
            kind = "an array" if f.array is not None else f.base
            raise FieldError(f"invalid field {'.'.join(path)!r}: {'.'.join(path[:i + 1])} is {kind}, "
                             "it has no fields")
        current = f.base


def _type_label(f: Any) -> str:
    return f.base if f is not None else "unknown"


def _abbreviate(value: list, f: Any) -> str:
    """ROS 2's stand-in for an array left out by --no-arr."""
    base = _type_label(f)
    if f is not None and f.array == "fixed":
        return f"<array type: {base}[{f.length}]>"
    if f is not None and f.array == "bounded":
        return f"<sequence type: {base}[{f.length}], length: {len(value)}>"
    return f"<sequence type: {base}, length: {len(value)}>"


@dataclass
class View:
    """The output options of one `topic echo`."""

    csv: bool = False
    as_json: bool = False
    no_arr: bool = False
    no_str: bool = False
    truncate: Optional[int] = DEFAULT_TRUNCATE
    field: Optional[list[str]] = None

    def select(self, plain: Any, type_name: Optional[str]) -> tuple[Any, Optional[str]]:
        """(the --field part of a plain message, its type name if it is a message); FieldError if absent."""
        if not self.field:
            return plain, type_name
        current = type_name
        for i, name in enumerate(self.field):
            if not isinstance(plain, dict) or name not in plain:
                have = ", ".join(plain) if isinstance(plain, dict) else type(plain).__name__
                raise FieldError(f"invalid field {'.'.join(self.field)!r}: {'.'.join(self.field[:i]) or 'the message'}"
                                 f" has no field {name!r} ({have})")
            d = _definition(current)
            f = next((f for f in d.fields if f.name == name), None) if d is not None else None
            current = f.base if f is not None and f.nested and f.array is None else None
            plain = plain[name]
        return plain, current

    def render(self, plain: Any, type_name: Optional[str]) -> str:
        """One message (already selected) as ros2 topic echo prints it, its `---` included (not for CSV)."""
        from .format import printable

        if self.as_json:  # (json.dumps escapes every control and non-ASCII character)
            return json.dumps(plain, default=_json_default, separators=(",", ":"))
        if self.csv:
            return printable(self._csv_message(plain, type_name) if isinstance(plain, dict)
                             else self._csv_value(plain, None))
        if not isinstance(plain, (dict, list, tuple, bytes, bytearray)):
            # a --field that is a single value: printed as ros2 prints it (str of the value)
            return "\n".join(printable(ln) for ln in self._csv_value(plain, None).split("\n")) + "\n---"
        import yaml

        data = self._message(plain, type_name) if isinstance(plain, dict) else self._value(plain, None, element=True)
        # YAML keeps NEL, bidi overrides and other format characters raw under allow_unicode: each line escaped
        text = yaml.safe_dump(data, sort_keys=False, default_flow_style=False, allow_unicode=True,
                              width=sys.maxsize).rstrip()
        return "\n".join(printable(line) for line in text.split("\n")) + "\n---"

    # ---- YAML: a plain structure with arrays and strings cut as asked
    def _message(self, plain: dict, type_name: Optional[str]) -> dict:
        d = _definition(type_name)
        fields = {f.name: f for f in d.fields} if d is not None else {}
        return {k: self._value(v, fields.get(k)) for k, v in plain.items()}

    def _value(self, v: Any, f: Any, element: bool = False) -> Any:
        nested = f.base if f is not None and f.nested else None
        if isinstance(v, (bytes, bytearray)):
            v = list(v)
        if isinstance(v, str):
            if self.no_str:
                return f"<string length: <{len(v)}>>"
            if self.truncate is not None and len(v) > self.truncate:
                return v[:self.truncate] + "..."
            return v
        if isinstance(v, (list, tuple)):
            if self.no_arr and not element:
                return _abbreviate(list(v), f)
            items = list(v)
            cut = self.truncate is not None and len(items) > self.truncate
            if cut:
                items = items[:self.truncate]
            out = [self._message(x, nested) if isinstance(x, dict) else self._value(x, None, True) for x in items]
            return out + ["..."] if cut else out
        if isinstance(v, dict):
            return self._message(v, nested)
        return v

    # ---- CSV: every leaf, depth first, comma separated
    def _csv_message(self, plain: dict, type_name: Optional[str]) -> str:
        d = _definition(type_name)
        fields = {f.name: f for f in d.fields} if d is not None else {}
        return ",".join(self._csv_value(v, fields.get(k)) for k, v in plain.items())

    def _csv_value(self, v: Any, f: Any, element: bool = False) -> str:
        nested = f.base if f is not None and f.nested else None
        if isinstance(v, (bytes, bytearray)):
            v = list(v)
        if isinstance(v, (list, tuple)):
            if self.no_arr and not element:
                return _abbreviate(list(v), f)
            parts = []
            for i, x in enumerate(v):
                if self.truncate is not None and i >= self.truncate:
                    parts.append("...")
                    break
                parts.append(self._csv_message(x, nested) if isinstance(x, dict) else self._csv_value(x, None, True))
            return ",".join(parts)
        if isinstance(v, dict):
            return self._csv_message(v, nested)
        if isinstance(v, str):
            if self.no_str:
                return f"<string length: <{len(v)}>>"
            if self.truncate is not None and len(v) > self.truncate:
                return v[:self.truncate] + "..."
        return str(v)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, (bytes, bytearray, memoryview)):
        return bytes(obj).hex()
    if hasattr(obj, "to_dict"):
        return obj.to_dict()
    return str(obj)

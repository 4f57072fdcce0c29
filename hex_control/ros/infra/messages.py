"""Message introspection without ros2cli: resolve types by name, read and write fields.

Built on what every generated rosidl Python class carries: ``get_fields_and_field_types()``
and ``SLOT_TYPES``. Used by the nodes (configurable input fields) and by ``hexctl topic``.
"""

from __future__ import annotations

import array
import importlib
import re

import numpy as np

_NESTED = re.compile(r"^(?:sequence<)?([a-zA-Z0-9_]+)/([a-zA-Z0-9_]+)(?:, ?\d+)?>?(?:\[\d*\])?$")


def message_class(type_name: str):
    """Class of a message type: ``pkg/msg/Type``, ``pkg/Type`` or ``pkg.msg.Type``, or a part
    of an action or service as the graph names it (``pkg/action/Name_Feedback``)."""
    parts = re.split(r"[/.]", type_name.strip())
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"not a message type name: {type_name!r} (want pkg/msg/Type)")
    package, kind, name = parts
    try:
        module = importlib.import_module(f"{package}.{kind}")
        if kind in ("action", "srv") and not hasattr(module, name) and "_" in name:
            base, _, part = name.rpartition("_")  # an action's or service's part: pkg/action/Name_Feedback
            cls = getattr(getattr(module, base), part)
        else:
            cls = getattr(module, name)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"unknown message type {type_name!r}: {exc}") from None
    if not hasattr(cls, "get_fields_and_field_types"):
        raise ValueError(f"{type_name!r} is not a message type")
    return cls


def type_name_of(cls) -> str:
    """``pkg/msg/Type`` of a message class."""
    module = cls.__module__.split(".")
    return f"{module[0]}/{module[1]}/{cls.__name__}"


def is_message(value) -> bool:
    return hasattr(value, "get_fields_and_field_types")


def _byte(value) -> int:
    """A single byte field (rclpy gives it as one-byte bytes) as its number."""
    return value[0] if isinstance(value, (bytes, bytearray)) else int(value)


def to_primitive(msg):
    """Nested dict / list / scalar form of a message (for YAML, JSON, tests)."""
    if is_message(msg):
        return {name: _byte(getattr(msg, name)) if kind in ("byte", "octet") else to_primitive(getattr(msg, name))
                for name, kind in msg.get_fields_and_field_types().items()}
    if isinstance(msg, (list, tuple, array.array)):
        return [to_primitive(v) for v in msg]
    if isinstance(msg, np.ndarray):
        return msg.tolist()
    if isinstance(msg, (bytes, bytearray)):
        return list(msg)
    if isinstance(msg, np.generic):
        return msg.item()
    return msg


def _nested_class(type_string: str):
    match = _NESTED.match(type_string)
    return message_class(f"{match.group(1)}/{match.group(2)}") if match else None


_INTEGER_BITS = {"int8": 8, "int16": 16, "int32": 32, "int64": 64, "uint8": 8, "uint16": 16,
                 "uint32": 32, "uint64": 64, "octet": 8, "char": 8, "byte": 8}
_ELEMENT = re.compile(r"^(?:sequence<([^,>]+)(?:, ?\d+)?>|([^\[]+)\[\d+\])$")


def _coerce(type_string: str, value, field: str):
    """A primitive field value checked and converted to what the C conversion accepts.

    The generated classes only check types with ROS_PYTHON_CHECK_FIELDS set; without
    this a wrong value would surface only at publish time, as an obscure error.
    """
    element = _ELEMENT.match(type_string)
    if element:
        if not isinstance(value, (list, tuple)):
            raise ValueError(f"field {field!r} ({type_string}) needs a list, got {value!r}")
        inner = element.group(1) or element.group(2)
        return [_coerce(inner, v, field) for v in value]
    base = type_string.split("<")[0]
    if base in ("double", "float"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"field {field!r} ({base}) needs a number, got {value!r}")
        return float(value)
    if base in _INTEGER_BITS:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"field {field!r} ({base}) needs an integer, got {value!r}")
        bits = _INTEGER_BITS[base]
        low, high = (0, 2**bits - 1) if base.startswith("u") or base in ("octet", "byte", "char") \
            else (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
        if not low <= value <= high:
            raise ValueError(f"field {field!r} ({base}) must be in [{low}, {high}], got {value}")
        return bytes([value]) if base in ("octet", "byte") else value
    if base == "boolean":
        if not isinstance(value, bool):
            raise ValueError(f"field {field!r} (boolean) needs true/false, got {value!r}")
        return value
    if base in ("string", "wstring"):
        if not isinstance(value, str):
            raise ValueError(f"field {field!r} (string) needs a string, got {value!r}")
        return value
    return value


def fill_message(msg, values: dict):
    """Set the fields of ``msg`` from a nested dict (as from YAML); returns ``msg``.

    Unknown field names raise ValueError naming the field; nested messages and
    sequences of messages are built recursively.
    """
    if not isinstance(values, dict):
        raise ValueError(f"expected a mapping of field names for {type(msg).__name__}, got {values!r}")
    fields = msg.get_fields_and_field_types()
    for name, value in values.items():
        if name not in fields:
            raise ValueError(f"{type(msg).__name__} has no field {name!r}; fields: {', '.join(fields)}")
        nested = _nested_class(fields[name])
        if nested is None:
            setattr(msg, name, _coerce(fields[name], value, name))
        elif fields[name].startswith("sequence<") or fields[name].endswith("]"):
            setattr(msg, name, [fill_message(nested(), v) for v in value])
        else:
            fill_message(getattr(msg, name), value)
    return msg


def get_field(msg, path: str):
    """Value at a dotted field path, e.g. ``wrench.force.z``; '' is the message itself."""
    value = msg
    for part in filter(None, path.split(".")):
        if not hasattr(value, "get_fields_and_field_types") or part not in value.get_fields_and_field_types():
            raise ValueError(f"{type(value).__name__} has no field {part!r} (path {path!r})")
        value = getattr(value, part)
    return value


def check_numeric_field(cls, path: str) -> None:
    """Raise ValueError unless ``path`` of a default ``cls()`` is a scalar number."""
    value = get_field(cls(), path)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"field {path!r} of {type_name_of(cls)} is not a number (got {type(value).__name__})")

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
    """Class of a message type: ``pkg/msg/Type``, ``pkg/Type`` or ``pkg.msg.Type``."""
    parts = re.split(r"[/.]", type_name.strip())
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"not a message type name: {type_name!r} (want pkg/msg/Type)")
    package, kind, name = parts
    try:
        module = importlib.import_module(f"{package}.{kind}")
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


def to_primitive(msg):
    """Nested dict / list / scalar form of a message (for YAML, JSON, tests)."""
    if is_message(msg):
        return {name: to_primitive(getattr(msg, name)) for name in msg.get_fields_and_field_types()}
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
            current = getattr(msg, name)
            if isinstance(current, float) and isinstance(value, int):
                value = float(value)
            setattr(msg, name, value)
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

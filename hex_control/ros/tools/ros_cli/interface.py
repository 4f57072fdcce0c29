"""``hexctl interface show TYPE``: an interface's definition as ``ros2 interface show``
prints it -- the file's text, each field of a message type followed by that type's fields
(without their comments), one tab deeper. Read from the installed interface packages'
share directories; no graph needed."""

from __future__ import annotations

import re

from hex_control.recording.bag import PRIMITIVES, interface_share
from hex_control.ros.tools.ros_cli.common import VerbError

KINDS = ("msg", "srv", "action")


def _path(type_name: str):
    """The definition file of ``pkg/kind/Name`` or ``pkg/Name`` (msg, then srv, then action)."""
    parts = re.split(r"[/.]", type_name.strip())
    if len(parts) not in (2, 3) or not all(parts) or (len(parts) == 3 and parts[1] not in KINDS):
        raise VerbError(f"not an interface type: {type_name!r} (want pkg/msg/Name, pkg/srv/Name or pkg/action/Name)")
    package, name = parts[0], parts[-1]
    try:
        share = interface_share(package)
    except ValueError:
        raise VerbError(f"unknown interface package {package!r} in {type_name!r}") from None
    for kind in (parts[1],) if len(parts) == 3 else KINDS:
        path = share / kind / f"{name}.{kind}"
        if path.is_file():
            return package, path
    raise VerbError(f"unknown interface type {type_name!r} (no such file in {share})")


def _field_type(line: str, package: str) -> str | None:
    """The ``pkg/msg/Type`` a definition line's field has, if a message type (not a
    primitive, not a constant, not a comment)."""
    tokens = line.split("#", 1)[0].split()
    if len(tokens) < 2 or "=" in tokens[1] or (len(tokens) > 2 and tokens[2].startswith("=")):
        return None
    base = re.split(r"[\[<]", tokens[0])[0]
    if base in PRIMITIVES:
        return None
    if base == "Header":
        return "std_msgs/msg/Header"
    if "/" in base:
        pkg, _, name = base.rpartition("/")
        return f"{pkg.split('/')[0]}/msg/{name}"
    return f"{package}/msg/{base}"


def _expanded(text: str, package: str, depth: int, nested: bool) -> list[str]:
    lines = []
    for line in text.splitlines():
        code = line.split("#", 1)[0].rstrip()
        if nested and not code.strip():
            continue  # nested types: their fields only, as ros2cli prints them
        lines.append("\t" * depth + (code.strip() if nested else line))
        field_type = _field_type(line, package)
        if field_type:
            nested_package, path = _path(field_type)
            lines += _expanded(path.read_text(), nested_package, depth + 1, True)
    return lines


def definition(type_name: str) -> str:
    package, path = _path(type_name)
    return "\n".join(_expanded(path.read_text(), package, 0, False))


def interface_show(type_name: str) -> int:
    print(definition(type_name))
    return 0
